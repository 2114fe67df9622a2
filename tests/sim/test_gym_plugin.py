"""``gymnasium.make("griploop/GraspLift-v0")`` works without importing ``sim`` first.

Gymnasium 1.x has no plugin discovery; the installed ``griploop-gymnasium.pth``
runs :func:`_griploop_gymnasium.install`, which registers the ids when
``gymnasium`` is imported.
"""

from __future__ import annotations

import os
import subprocess
import sys
import sysconfig
import venv
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
MAKE = """\
import sys
import gymnasium
assert "sim" not in sys.modules, "sim imported before make"
env = gymnasium.make("griploop/GraspLift-v0", object="can", reference=15.0)
obs, info = env.reset(seed=0)
print(type(env.unwrapped).__module__, obs.shape)
"""


def _env(**extra: str) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env["OMP_NUM_THREADS"] = "1"
    env.update(extra)
    return env


def test_hook_registers_when_gymnasium_is_imported(tmp_path):
    code = "import _griploop_gymnasium; _griploop_gymnasium.install()\n" + MAKE
    proc = subprocess.run([sys.executable, "-c", code], cwd=tmp_path,
                          env=_env(PYTHONPATH=str(ROOT)), capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split()[0] == "sim.hand.grasp_env"


def test_hook_and_sim_registration_agree():
    import gymnasium

    import _griploop_gymnasium
    from sim.hand.registration import GRASP_LIFT_ID

    assert set(_griploop_gymnasium.ENVIRONMENTS) == {GRASP_LIFT_ID}
    spec = gymnasium.spec(GRASP_LIFT_ID)
    assert spec.entry_point == _griploop_gymnasium.ENVIRONMENTS[GRASP_LIFT_ID]


def test_pth_file_calls_the_hook():
    line = (ROOT / "griploop-gymnasium.pth").read_text().strip()
    assert line == "import _griploop_gymnasium; _griploop_gymnasium.install()"


@pytest.mark.slow
@pytest.mark.parametrize("editable", [False, True], ids=["wheel", "editable"])
def test_make_works_after_installing(tmp_path, editable):
    """Install the project (no dependencies) into a fresh venv that sees this one's packages."""
    target = tmp_path / "venv"
    venv.create(target, with_pip=True)
    python = target / "bin" / "python"
    site = subprocess.run([python, "-c", "import sysconfig; print(sysconfig.get_path('purelib'))"],
                          capture_output=True, text=True, check=True).stdout.strip()
    (Path(site) / "zz-dependencies.pth").write_text(sysconfig.get_path("purelib") + "\n")
    install = [python, "-m", "pip", "install", "-q", "--no-deps", *(["-e"] if editable else []),
               str(ROOT)]
    proc = subprocess.run(install, capture_output=True, text=True, timeout=300, env=_env())
    if proc.returncode and "No matching distribution" in proc.stderr:
        pytest.skip("no package index for the build requirements")
    assert proc.returncode == 0, proc.stderr
    assert (Path(site) / "griploop-gymnasium.pth").is_file()
    proc = subprocess.run([python, "-c", MAKE], cwd=tmp_path, env=_env(), capture_output=True,
                          text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split()[0] == "sim.hand.grasp_env"
