"""Suite-wide setup: headless rendering backends, chosen before mujoco or matplotlib load."""

import atexit
import os
import shutil
import tempfile

os.environ.setdefault("MUJOCO_GL", "egl")
os.environ.setdefault("PYOPENGL_PLATFORM", os.environ["MUJOCO_GL"])
# Plant families are cached on disk (controllers.plant_cache): the suite uses its own
# directory, shared by its subprocesses, never the user's cache.
if "GRIPLOOP_CACHE_DIR" not in os.environ:
    os.environ["GRIPLOOP_CACHE_DIR"] = tempfile.mkdtemp(prefix="griploop-test-cache-")
    atexit.register(shutil.rmtree, os.environ["GRIPLOOP_CACHE_DIR"], ignore_errors=True)
os.environ.setdefault("MPLBACKEND", "Agg")
