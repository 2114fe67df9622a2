"""Processor in the loop: the episode with its own estimator and controller compiled.

The compiled pair runs in float32; the Python pair in float64. The outcome, the held
force (within 1 %) and the user's corrections must be those of the Python run of the
same seed, for PID and lead-lag on the can and the egg with two estimators.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from scenarios.cli import main
from scenarios.deploy.library import CompiledController
from scenarios.runners.episode import run_episode
from sim.hand.objects import make_object
from sim.user.subjects import VirtualSubject

SUBJECT = VirtualSubject.sample(0, 3)


def _episode(estimator, controller, object_name, compiled):
    return run_episode(SUBJECT, make_object(object_name), estimator=estimator,
                       controller=controller, seed=0, compiled=compiled)


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
    # the grip over the last second, measured on the hand, within 1 % too
    grip_py, grip_c = (float(np.mean(r.traces["grip_force_n"][-100:])) for r in (py, c))
    assert grip_c == pytest.approx(grip_py, rel=0.01)
    # and the run is not a copy: the compiled commands differ by float32 rounding only
    n = min(py.traces["command"].size, c.traces["command"].size)
    assert np.max(np.abs(py.traces["command"][:n] - c.traces["command"][:n])) < 0.05


def test_episode_compiled_on_the_command_line(c_compiler, tmp_path, capsys):
    out = tmp_path / "episode.json"
    assert main(["episode", "--controller", "pid", "--estimator", "ss_kf", "--object", "egg",
                 "--subject", "3", "--compiled", "--json", str(out)]) == 0
    data = json.loads(out.read_text())
    assert data["metrics"]["outcome"] == "held"
    assert len(data["compiled"]["controller_digest"]) == 16
