"""A sweep records real failures as rows with their reason, and the report lists them."""

from __future__ import annotations

import numpy as np

import sim.hand.grasp_env
from scenarios.execution.sweep import plan, run_sweep
from scenarios.report import build_report
from scenarios.schema import expand_sweep, parse_sweep
from scenarios.store import ResultStore

SWEEP = {
    "name": "failures",
    "seed": 3,
    "base": {"kind": "episode", "object": {"name": "block"},
             "estimator": {"name": "oracle"}, "controller": {"kind": "pid"}},
    "grid": {"object.mass_kg": [0.3]},
}


def test_raise_divergence_and_infeasible_design_become_failed_rows(tmp_path, monkeypatch):
    original_step = sim.hand.grasp_env.GraspEnv.step

    def diverging_step(self, action):
        # a NaN velocity in the block's scenario: MuJoCo flags BADQVEL, as in a blow-up
        if self.object_spec.friction == 0.9 and self._step_count == 40:
            self.data.qvel[0] = np.nan
        return original_step(self, action)

    monkeypatch.setattr(sim.hand.grasp_env.GraspEnv, "step", diverging_step)
    specs = {
        "raises": {"estimator": {"name": "persistence", "mode": "free_run"}},
        "diverges": {"object": {"name": "block", "friction": 0.9}},
        "infeasible": {"controller": {"kind": "pid", "phase_margin_deg": 89.0,
                                      "crossover_rad_s": 250.0}},
        "fine": {},
    }
    planned = []
    for name, override in specs.items():
        sweep = {**SWEEP, "name": name,
                 "base": {**SWEEP["base"], **{k: {**SWEEP["base"].get(k, {}), **v}
                                              for k, v in override.items()}}}
        planned += plan(expand_sweep(parse_sweep(sweep)), "scenarios.runners.dispatch:run_scenario")
    db = tmp_path / "r.sqlite"
    with ResultStore(db) as store:
        summary = run_sweep(planned, store, progress=False, sweep_name="failures")
        rows = store.rows()
    outcomes = [(r["status"], r["error"]) for r in rows]
    assert summary.ok == 1 and summary.failed == 3, outcomes
    errors = [error for status, error in outcomes if status == "failed"]
    assert any("persistence has modes" in e for e in errors), errors
    assert any("physics diverged" in e and "BADQVEL" in e for e in errors), errors
    assert any("phase margin 89" in e for e in errors), errors
    html = build_report(db, tmp_path / "report", render_frame=False).path.read_text()
    for needle in ("persistence has modes", "physics diverged", "phase margin 89"):
        assert needle in html
