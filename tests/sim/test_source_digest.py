"""sim.cache.source_digest: the source a cached result is computed by, subpackages included."""

from __future__ import annotations

import sys

from sim.cache import source_digest


def test_an_edit_in_a_subpackage_changes_the_digest_and_bytecode_does_not(tmp_path,
                                                                          monkeypatch):
    pkg = tmp_path / "digest_probe_pkg"
    (pkg / "sub" / "__pycache__").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "sub" / "__init__.py").write_text("")
    (pkg / "sub" / "trainer.py").write_text("RATE = 1\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    try:
        first = source_digest(["digest_probe_pkg"])
        (pkg / "sub" / "__pycache__" / "trainer.cpython.pyc").write_bytes(b"compiled")
        assert source_digest(["digest_probe_pkg"]) == first
        (pkg / "sub" / "trainer.py").write_text("RATE = 2\n")
        assert source_digest(["digest_probe_pkg"]) != first
    finally:
        sys.modules.pop("digest_probe_pkg", None)
