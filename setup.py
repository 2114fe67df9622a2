"""Setuptools hook: ship ``griploop-gymnasium.pth`` at the top of site-packages.

Everything else is in ``pyproject.toml``. The ``.pth`` file registers griploop's
Gymnasium ids when ``gymnasium`` is imported (see ``_griploop_gymnasium.py``),
because Gymnasium 1.x no longer discovers plugins through entry points.
"""

from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

PTH = "griploop-gymnasium.pth"


class BuildPyWithPth(build_py):
    """``build_py`` that also copies the ``.pth`` file into the wheel's root."""

    def run(self) -> None:
        super().run()
        self.copy_file(str(Path(__file__).parent / PTH), str(Path(self.build_lib) / PTH),
                       preserve_mode=0)

    def get_outputs(self, include_bytecode: bool = True) -> list[str]:
        return [*super().get_outputs(include_bytecode), str(Path(self.build_lib) / PTH)]


cmdclass = {"build_py": BuildPyWithPth}

try:  # editable installs (PEP 660) build no wheel root from build_py: add the file there too
    from setuptools.command.editable_wheel import editable_wheel

    class EditableWheelWithPth(editable_wheel):
        """``editable_wheel`` that also puts the ``.pth`` file in the wheel's root."""

        def _run_build_commands(self, dist_name, unpacked_wheel, build_lib, tmp_dir):
            result = super()._run_build_commands(dist_name, unpacked_wheel, build_lib, tmp_dir)
            self.copy_file(str(Path(__file__).parent / PTH), str(Path(unpacked_wheel) / PTH),
                           preserve_mode=0)
            return result

    cmdclass["editable_wheel"] = EditableWheelWithPth
except ImportError:  # setuptools < 64: editable installs go through develop
    pass

setup(cmdclass=cmdclass)
