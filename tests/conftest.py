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


# ------------------------------------------------------------ parallel workers: one thread
def pytest_configure(config):
    """On a parallel run (``-n N``), each worker computes on one thread.

    A worker per core already fills the cores: BLAS and OpenMP threads of their own
    (OpenBLAS starts one per core, scikit-learn's gradient boosting too) would only
    oversubscribe them. Set before the workers start, so their numpy reads it on import;
    a value the user exported wins.
    """
    workers = getattr(config.option, "numprocesses", None)
    if workers and not hasattr(config, "workerinput"):
        for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
            os.environ.setdefault(var, "1")


# ---------------------------------------------------------------- order of the test files
# ``make test`` runs the files on pytest-xdist workers, whole (``--dist loadfile``), in
# collection order as workers free up. A long file started last keeps one worker busy while
# the others have nothing left, so the longest files go first: as long as they took in the
# previous run (kept in pytest's cache), and, before any run, files marked ``slow`` at
# module level. Within a file the order is unchanged.
_DURATIONS_KEY = "griploop/file-durations"
_UNKNOWN_SLOW_S = 60.0  # a module marked slow and not timed yet


def pytest_collection_modifyitems(config, items):
    cache = getattr(config, "cache", None)  # None under -p no:cacheprovider
    known = cache.get(_DURATIONS_KEY, {}) if cache is not None else {}

    def expected_s(item) -> float:
        path = item.nodeid.split("::")[0]
        if path in known:
            return float(known[path])
        module_marks = getattr(item.module, "pytestmark", [])
        if not isinstance(module_marks, list):
            module_marks = [module_marks]
        return _UNKNOWN_SLOW_S if any(m.name == "slow" for m in module_marks) else 0.0

    first_seen = {}
    for i, item in enumerate(items):
        first_seen.setdefault(item.nodeid.split("::")[0], i)
    weight = {path: 0.0 for path in first_seen}
    for item in items:
        path = item.nodeid.split("::")[0]
        weight[path] = max(weight[path], expected_s(item))
    items.sort(key=lambda it: (-weight[it.nodeid.split("::")[0]],
                               first_seen[it.nodeid.split("::")[0]]))


_spent: dict[str, float] = {}


def pytest_runtest_logreport(report):
    path = report.nodeid.split("::")[0]
    _spent[path] = _spent.get(path, 0.0) + report.duration


def pytest_sessionfinish(session):
    config = session.config
    if getattr(config, "cache", None) is None or hasattr(config, "workerinput") or not _spent:
        return  # xdist workers report to the controller, which keeps the figures
    known = dict(config.cache.get(_DURATIONS_KEY, {}))
    known.update({path: round(s, 2) for path, s in _spent.items()})
    config.cache.set(_DURATIONS_KEY, known)
