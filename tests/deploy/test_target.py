"""The replay on the emulated Cortex-M4F: the same bits as the host build, sizes, instructions."""

from __future__ import annotations

import pytest

from scenarios.deploy.session import ExportSpec, export_session
from scenarios.runners.trial_loop import HandSettings

pytestmark = pytest.mark.target

@pytest.mark.parametrize(("estimator", "controller", "paradigm"),
                         [("ss_kf", "pid", "force"), ("mlp", "lead_lag", "force_hold")])
def test_the_target_replay_equals_the_host_build(arm_tools, c_compiler, sessions, tmp_path,
                                                 estimator, controller, paradigm):
    fit, replay = sessions
    spec = ExportSpec(estimator, [6, 7, 8], controller=controller, object_name="can",
                      hand=HandSettings(paradigm=paradigm))
    export, report = export_session(fit, spec, tmp_path, check_recording=replay,
                                    target="cortex-m4")
    t = report["target"]
    assert t["matches_host"], t["max_abs_difference_from_host"]
    # features, estimate and hand reference of every window, and every command
    windows, steps = report["check"]["windows"], report["check"]["control_steps"]
    assert t["outputs_compared"] == windows * (export.window.n_features + 2) + steps
    assert t["outputs_compared"] > 5000
    ipu = t["instructions_per_update"]
    assert 0 < ipu["controller"] < 2000
    if estimator == "ss_kf":  # the paper's estimator with its features: the goal
        assert ipu["features"] + ipu["estimator"] < 20_000
        assert t["ram_bytes"] < 8 * 1024
        # a window of 25 frames costs more than 25 pushes' bookkeeping: it is counted
        assert ipu["features"] > 25 * 20
