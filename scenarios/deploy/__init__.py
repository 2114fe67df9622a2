"""Deploying what was evaluated: C export, host build, replay checks, the emulated target.

- :mod:`.writer`: :func:`~scenarios.deploy.writer.export_c`, the Python API of
  ``griploop export-c``;
- :mod:`.build`: the host C compiler into a shared library;
- :mod:`.library`: that library through ctypes (features, estimator stream, controller);
- :mod:`.check`: a recording replayed through C and Python, sample for sample;
- :mod:`.compiled`: ``griploop episode --compiled``, the compiled pair in the closed loop;
- :mod:`.target`: the Cortex-M4F build run on QEMU's ``mps2-an386`` (outputs, sizes,
  instructions per update).
"""
