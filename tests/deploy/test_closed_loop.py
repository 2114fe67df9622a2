"""Processor in the loop: the episode with its own estimator and controller compiled.

The compiled pair runs in float32; the Python pair in float64. The outcome, the held
force (the mean grip in the air, within 1 %), the user's corrections and attempts must be
those of the Python run of the same seed, for PID and lead-lag on the can and the egg
with two estimators. The user practised with the Python pair (the same prosthesis).
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from scenarios.cli import main
from scenarios.deploy.library import CompiledController
from scenarios.runners.episode import EpisodeSpec, run_episode
from sim.hand.objects import make_object
from sim.user.subjects import VirtualSubject

SUBJECT = VirtualSubject.sample(0, 3)


def _episode(estimator, controller, object_name, compiled):
    return run_episode(SUBJECT, make_object(object_name), EpisodeSpec(estimator=estimator,
                                                                      controller=controller,
                                                                      seed=0), compiled=compiled)


@pytest.mark.parametrize("estimator", ["ss_kf", "mlp"])
@pytest.mark.parametrize(("controller", "object_name"), [
    ("pid", "can"), ("lead_lag", "can"), ("pid", "egg"), ("lead_lag", "egg")])
def test_the_compiled_episode_matches_the_python_one(c_compiler, estimator, controller,
                                                     object_name):
    py = _episode(estimator, controller, object_name, False)
    c = _episode(estimator, controller, object_name, True)
    assert isinstance(c.design.controller, CompiledController)
    assert c.row["outcome"] == py.row["outcome"]
    assert c.row["user_corrections"] == py.row["user_corrections"]
    if py.row["held_force_n"] is None:
        assert c.row["held_force_n"] is None
    else:
        assert c.row["held_force_n"] == pytest.approx(py.row["held_force_n"], rel=0.01)
    assert c.row["attempts"] == py.row["attempts"]
    # and the run is not a copy: until the hand touches the object (after which the
    # contact makes any rounding grow), the compiled commands differ by float32 rounding
    both = np.flatnonzero(py.traces["both_sides"])
    n = int(both[0]) if both.size else py.traces["command"].size
    diff = np.abs(py.traces["command"][:n] - c.traces["command"][:n])
    assert 0 < np.max(diff) < 1e-3 or np.array_equal(py.traces["command"][:n],
                                                     c.traces["command"][:n])


def test_episode_compiled_on_the_command_line(c_compiler, tmp_path, capsys):
    argv = ["episode", "--controller", "pid", "--estimator", "ss_kf", "--object", "egg",
            "--subject", "3"]
    runs = {}
    for flags in ([], ["--compiled"]):
        out = tmp_path / f"episode{len(flags)}.json"
        assert main([*argv, *flags, "--json", str(out)]) == 0
        runs[bool(flags)] = json.loads(out.read_text())
    assert runs[True]["metrics"]["outcome"] == runs[False]["metrics"]["outcome"]
    assert runs[False]["compiled"] is None
    assert len(runs[True]["compiled"]["controller_digest"]) == 16
