"""Compiling an export: the host's C compiler into a shared library (for ctypes).

The flags are the ones the equivalence was measured with: C99, no fused
multiply-add (``-ffp-contract=off``, so the host and the Cortex-M4F round alike),
``-fno-math-errno`` (square roots become one instruction), warnings on.
"""

from __future__ import annotations

import os
import shutil
import subprocess
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from sim.errors import GriploopError

#: Flags of every build of an export (host and target).
C_FLAGS = ("-std=c99", "-O2", "-ffp-contract=off", "-fno-math-errno", "-Wall", "-Wextra",
           "-Wpedantic")
HOST_INSTALL = "apt-get install gcc (Debian) or set CC to a C99 compiler"


class CompilerMissingError(GriploopError, RuntimeError):
    """No C compiler on this machine: says what to install."""


class BuildError(GriploopError, RuntimeError):
    """The compiler refused the exported files (its first error line is in the message)."""


def host_compiler() -> str:
    """The C compiler: ``$CC``, else ``cc`` or ``gcc`` on the PATH.

    Raises
    ------
    CompilerMissingError
        None found; the message says what to install.
    """
    for name in (os.environ.get("CC"), "cc", "gcc"):
        if name and shutil.which(name):
            return str(shutil.which(name))
    raise CompilerMissingError(f"no C compiler found to build the export: {HOST_INSTALL}")


def run_compiler(command: Sequence[str], what: str) -> str:
    """Run a compiler command; return its warnings (stderr).

    Raises
    ------
    BuildError
        Non-zero exit; the message has the first error line.
    """
    proc = subprocess.run(list(command), capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        lines = [ln for ln in proc.stderr.splitlines() if "error" in ln] or \
            proc.stderr.splitlines() or ["(no output)"]
        raise BuildError(f"{what} failed: {lines[0].strip()}")
    return proc.stderr


def compile_shared(sources: Sequence[Path], out: Path, *, extra: Sequence[str] = ()) -> str:
    """Compile C files into the shared library ``out`` with the host compiler.

    Parameters
    ----------
    sources : sequence of Path
        ``.c`` files (their headers beside them).
    out : Path
        The ``.so`` to write.
    extra : sequence of str
        More flags (e.g. ``-DGRIPLOOP_DOUBLE``).

    Returns
    -------
    str
        The compiler's warnings (empty for a clean build).

    Raises
    ------
    CompilerMissingError, BuildError
    """
    cc = host_compiler()
    command = [cc, *C_FLAGS, "-fPIC", "-shared", *extra, "-o", str(out),
               *(str(s) for s in sources), "-lm"]
    return run_compiler(command, f"{Path(cc).name} (host build)")


def build_export(export: Any, build_dir: Path | None = None) -> tuple[Path, str]:
    """Compile an export (with the runtime's replay harness) into a host shared library.

    Parameters
    ----------
    export : scenarios.deploy.writer.CExport
    build_dir : Path, optional
        Where the harness and the library go (default: ``export.out_dir / "build"``).

    Returns
    -------
    library : Path
    warnings : str
        The compiler's warnings (empty for a clean build).
    """
    build_dir = Path(build_dir or export.out_dir / "build")
    build_dir.mkdir(parents=True, exist_ok=True)
    harness = build_dir / "griploop_harness.c"
    harness.write_text(export.harness(), encoding="utf-8")
    out = build_dir / "libgriploop.so"
    warnings = compile_shared([*export.sources, harness], out, extra=[f"-I{export.out_dir}"])
    return out, warnings
