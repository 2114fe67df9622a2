"""Sweep engine: planning, in-process and dask execution, failures, resume, progress."""

from __future__ import annotations

import io
import os

import numpy as np
import pytest
import tasks

from scenarios.execution.sweep import (
    DEFAULT_TASK,
    Progress,
    SweepError,
    SweepExecution,
    execute,
    pending,
    plan,
    run_sweep,
    split_result,
    task_name,
)
from scenarios.runners import dispatch as runner
from scenarios.schema import Scenario, expand_sweep, parse_sweep
from scenarios.store import ResultStore, package_version


def sweep_spec(masses=(0.1, 0.5, 1.5), kinds=("pid", "mpc")):
    return parse_sweep(
        {
            "name": "engine",
            "seed": 4,
            "base": {"object": {"name": "cup"}},
            "grid": {"object.mass_kg": list(masses), "controller.kind": list(kinds)},
        }
    )


def planned(task="tasks:seeded", **kw):
    return plan(expand_sweep(sweep_spec(**kw)), task)


def by_hash(store):
    return {r["hash"]: r for r in store.rows()}


# ------------------------------------------------------------------ planning


def test_task_names():
    assert task_name(tasks.seeded) == "tasks:seeded"
    assert task_name("tasks:seeded") == "tasks:seeded"
    with pytest.raises(SweepError, match="importable module-level function"):
        task_name(lambda s: {})
    with pytest.raises(SweepError, match="'package.module:function'"):
        task_name("tasks.seeded")


def test_plan_hashes_depend_on_task_and_version():
    a = planned("tasks:seeded")
    b = planned("tasks:sleepy")
    c = plan(expand_sweep(sweep_spec()), "tasks:seeded", version="0.0.0")
    assert len({p.hash for p in a}) == len(a) == 6
    assert not {p.hash for p in a} & {p.hash for p in b}
    assert not {p.hash for p in a} & {p.hash for p in c}
    assert [p.hash for p in a] == [p.hash for p in planned("tasks:seeded")]


def test_plan_rejects_identical_scenarios():
    spec = parse_sweep({"base": {}, "grid": {"seed": [1, 2, 1]}})
    with pytest.raises(SweepError, match="scenarios 0 and 2 are identical"):
        plan(expand_sweep(spec), "tasks:seeded")


# ------------------------------------------------------------------ execution


def test_split_result_converts_numpy_scalars_and_rejects_arrays():
    scalars, traces = split_result({"a": np.float64(1.5), "b": np.int32(2), "c": None})
    assert scalars == {"a": 1.5, "b": 2, "c": None} and type(scalars["b"]) is int
    assert traces is None
    with pytest.raises(TypeError, match="put arrays under 'traces'"):
        split_result({"x": np.zeros(3)})
    with pytest.raises(TypeError, match="must return a mapping"):
        split_result([1, 2])


def test_execute_turns_an_exception_into_a_failed_outcome():
    sc = Scenario.model_validate({"object": {"mass_kg": 1.5}, "seed": 1})
    out = execute("tasks:heavy_fails", sc, "h")
    assert out.status == "failed" and out.result == {}
    assert out.error == "ValueError: object of 1.5 kg slipped out of the hand"
    assert "Traceback" in out.traceback and "heavy_fails" in out.traceback
    assert out.duration_s >= 0 and out.finished_at >= out.started_at


def test_in_process_sweep_matches_an_independent_recomputation(tmp_path):
    items = planned()
    with ResultStore(tmp_path / "r.sqlite") as store:
        summary = run_sweep(items, store, SweepExecution("tasks:seeded"), progress=False,
                            sweep_name="s")
        rows = by_hash(store)
        traces = store.traces(items[0].hash)
    assert (summary.total, summary.skipped, summary.ok, summary.failed) == (6, 0, 6, 0)
    for p in items:
        rng = np.random.default_rng(p.scenario.seed)
        draws = rng.standard_normal(3)
        result = rows[p.hash]["result"]
        assert result["draw"] == float(draws[0])
        assert result["draw_sum"] == float(draws.sum())
        assert result["mass_kg"] == p.scenario.object.mass_kg
        assert rows[p.hash]["version"] == package_version()
    rng = np.random.default_rng(items[0].scenario.seed)
    rng.standard_normal(3)
    np.testing.assert_array_equal(traces["force_n"], rng.standard_normal((50, 2)))


def test_failures_become_rows_and_the_sweep_goes_on(tmp_path):
    items = planned("tasks:heavy_fails")
    with ResultStore(tmp_path / "r.sqlite") as store:
        summary = run_sweep(items, store, SweepExecution("tasks:heavy_fails"), progress=False)
        failed = store.rows(status="failed")
    assert (summary.ok, summary.failed) == (4, 2)
    assert {r["config"]["object"]["mass_kg"] for r in failed} == {1.5}
    assert all("slipped out of the hand" in r["error"] for r in failed)
    assert all("Traceback" in r["traceback"] for r in failed)


def test_invalid_result_row_is_a_failed_row(tmp_path):
    items = planned("tasks:returns_array", masses=(0.2,), kinds=("pid",))
    with ResultStore(tmp_path / "r.sqlite") as store:
        run_sweep(items, store, SweepExecution("tasks:returns_array"), progress=False)
        (row,) = store.rows()
    assert row["status"] == "failed" and row["error"].startswith("TypeError: result 'force_n'")


def test_rerun_skips_finished_rows_and_retry_reruns_failed(tmp_path):
    items = planned("tasks:heavy_fails")
    with ResultStore(tmp_path / "r.sqlite") as store:
        first = run_sweep(items[:3], store, SweepExecution("tasks:heavy_fails"), progress=False)
        before = {r["hash"]: r["finished_at"] for r in store.rows()}
        second = run_sweep(items, store, SweepExecution("tasks:heavy_fails"), progress=False)
        after = by_hash(store)
        assert pending(items, store) == []
        assert [p.hash for p in pending(items, store, retry_failed=True)] == [
            p.hash for p in items if p.scenario.object.mass_kg == 1.5
        ]
        third = run_sweep(items, store, SweepExecution("tasks:heavy_fails"), progress=False,
                          retry_failed=True)
        attempts = {r["hash"]: r["attempts"] for r in store.rows()}
    assert first.ok + first.failed == 3
    assert (second.total, second.skipped, second.ok + second.failed) == (6, 3, 3)
    assert len(after) == 6
    assert all(after[h]["finished_at"] == t for h, t in before.items())
    assert (third.skipped, third.failed) == (4, 2)
    assert sorted(attempts.values()) == [1, 1, 1, 1, 2, 2]


@pytest.fixture
def bare_registry(monkeypatch):
    """Only the reproduction runner, as in a build without the closed-loop stack."""
    monkeypatch.setattr(runner, "_REGISTRY",
                        {k: v for k, v in runner._REGISTRY.items() if k == "reproduction"})


def test_default_task_without_runner_fails_before_running(tmp_path, bare_registry):
    items = planned(DEFAULT_TASK)
    with ResultStore(tmp_path / "r.sqlite") as store:
        with pytest.raises(runner.RunnerUnavailableError, match="kind 'episode'"):
            run_sweep(items, store, progress=False)
        assert store.counts() == {"ok": 0, "failed": 0}


def test_registered_runner_is_dispatched_by_kind(tmp_path, bare_registry):
    items = planned(DEFAULT_TASK, masses=(0.2,), kinds=("pid",))
    runner.register_runner("episode", "tasks:seeded")
    try:
        with pytest.raises(ValueError, match="already registered"):
            runner.register_runner("episode", tasks.sleepy)
        with ResultStore(tmp_path / "r.sqlite") as store:
            summary = run_sweep(items, store, progress=False)
            (row,) = store.rows()
    finally:
        runner.unregister_runner("episode")
    assert summary.ok == 1
    assert row["result"]["kind"] == "episode" and row["result"]["mode"] == "free_run"
    assert row["result"]["draw"] == float(
        np.random.default_rng(items[0].scenario.seed).standard_normal(3)[0]
    )
    assert runner.registered_kinds() == ("reproduction",)


def test_runner_registration_is_checked(bare_registry):
    with pytest.raises(ValueError, match="scenario kind must be one of"):
        runner.register_runner("report", tasks.seeded)
    with pytest.raises(ValueError, match="'package.module:function'"):
        runner.register_runner("episode", "tasks.seeded")
    runner.register_runner("calibration", "no_such_module_xyz:run")
    try:
        with pytest.raises(runner.RunnerUnavailableError, match="cannot be imported"):
            runner.get_runner("calibration")
    finally:
        runner.unregister_runner("calibration")


# ------------------------------------------------------------------ reproduction runner


def reproduction(name="ss_kf", mode="one_step", seed=5, **protocol):
    return Scenario.model_validate({
        "kind": "reproduction",
        "subject": {"subject_id": 2},
        "protocol": {"name": "paper_calibration", **protocol},
        "estimator": {"name": name, "mode": mode},
        "seed": seed,
    })


def test_reproduction_row_is_consistent_with_its_own_traces():
    row = runner.run_scenario(reproduction())
    y, y_hat = row["traces"]["force_n"], row["traces"]["force_hat_n"]
    r2 = 1.0 - np.sum((y - y_hat) ** 2) / np.sum((y - y.mean()) ** 2)
    assert row["r2"] == pytest.approx(r2, rel=1e-9)
    assert row["nrmse"] == pytest.approx(1.0 - np.sqrt(1.0 - r2), rel=1e-9)
    assert row["rmse_n"] == pytest.approx(np.sqrt(np.mean((y - y_hat) ** 2)), rel=1e-9)
    assert y.shape == (row["n_windows"] - row["n_identification"],)
    assert row["n_identification"] == row["n_windows"] // 2
    assert 45.0 <= row["session_s"] <= 80.0  # the paper session's length (two rounds)
    assert 0.5 < row["r2"] <= 1.0 and row["order"] == 4  # one-step SS+KF fits well
    assert (row["kind"], row["mode"], row["estimator"]) == ("reproduction", "one_step", "ss_kf")
    np.testing.assert_allclose(np.diff(row["traces"]["t_s"]), 0.125)  # paper's increment


def test_reproduction_is_deterministic_in_its_seed():
    a, b = runner.run_scenario(reproduction()), runner.run_scenario(reproduction())
    c = runner.run_scenario(reproduction(seed=6))
    assert a["r2"] == b["r2"]
    np.testing.assert_array_equal(a["traces"]["force_hat_n"], b["traces"]["force_hat_n"])
    assert a["r2"] != c["r2"]


def test_reproduction_refuses_what_it_cannot_honour():
    out = execute(DEFAULT_TASK, reproduction("persistence", "free_run"), "h")
    assert out.status == "failed"
    assert out.error == ("UnsupportedScenarioError: estimator persistence has modes "
                         "('one_step',) (found mode free_run)")
    with pytest.raises(runner.UnsupportedScenarioError, match="calibration_s unset"):
        runner.run_scenario(reproduction(calibration_s=40.0))


def test_workers_must_be_positive(tmp_path):
    with ResultStore(tmp_path / "r.sqlite") as store:
        with pytest.raises(SweepError, match="workers must be >= 1"):
            run_sweep(planned(), store, SweepExecution("tasks:seeded", workers=0))


# ------------------------------------------------------------------ progress


def test_progress_line_counts_rate_and_eta():
    stream = io.StringIO()
    bar = Progress(4, "demo", stream, log_interval_s=1e9)
    for status in ("ok", "failed", "ok", "ok"):
        bar.update(status)
    bar.close()
    lines = stream.getvalue().splitlines()
    assert len(lines) == 4  # not a tty: one whole line per tenth of 4 scenarios, no \r
    assert "\r" not in stream.getvalue()
    assert lines[-1].startswith("demo 100%|########################| 4/4 done, 1 failed [")
    assert lines[0].startswith("demo  25%|######                  | 1/4 done, 0 failed [")
    assert "scenario/s" in lines[0] or "s/scenario" in lines[0]


def test_progress_redraws_in_place_on_a_terminal():
    class Tty(io.StringIO):
        def isatty(self):
            return True

    stream = Tty()
    bar = Progress(2, "t", stream, min_interval_s=0.0)
    bar.update("ok")
    bar.total = 3  # scenarios found while running change the total
    bar.update("failed")
    bar.close()
    text = stream.getvalue()
    assert text.count("\r") >= 2 and text.endswith("\n") and text.count("\n") == 1
    assert "2/3 done, 1 failed" in text.rsplit("\r", 1)[-1]


# ------------------------------------------------------------------ dask


@pytest.mark.slow
def test_dask_results_equal_in_process_results(tmp_path):
    """Same sweep in-process, on a 2-worker LocalCluster and on an existing scheduler."""
    from distributed import LocalCluster

    items = planned("tasks:heavy_fails", masses=(0.1, 0.3, 0.5, 1.5), kinds=("pid", "mpc"))
    runs = {"in-process": {"workers": 1}, "local-cluster": {"workers": 2}}
    results, workers_seen = {}, {}
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True,
                      dashboard_address=":0") as cluster:
        runs["scheduler"] = {"scheduler": cluster.scheduler_address}
        for name, options in runs.items():
            with ResultStore(tmp_path / f"{name}.sqlite") as store:
                summary = run_sweep(items, store, SweepExecution(tasks.heavy_fails, **options),
                                    progress=False)
                assert (summary.ok, summary.failed) == (6, 2)
                rows = by_hash(store)
                results[name] = {
                    h: (r["status"], r["result"], r["error"], store.traces(h).get("force_n"))
                    for h, r in rows.items()
                }
                workers_seen[name] = {r["worker"].split(":")[1] for r in rows.values()}
    reference = results["in-process"]
    assert reference.keys() == {p.hash for p in items}
    for name in ("local-cluster", "scheduler"):
        assert results[name].keys() == reference.keys()
        for h, (status, result, error, trace) in reference.items():
            status2, result2, error2, trace2 = results[name][h]
            assert (status, result, error) == (status2, result2, error2)
            if trace is None:
                assert trace2 is None
            else:
                np.testing.assert_array_equal(trace, trace2)
    # one worker: every scenario ran in the same child process of the driver (its Sandbox)
    assert len(workers_seen["in-process"]) == 1
    assert workers_seen["in-process"] != {str(os.getpid())}
    assert str(os.getpid()) not in workers_seen["local-cluster"] | workers_seen["scheduler"]


def test_bad_scheduler_address_is_a_sweep_error(tmp_path):
    with ResultStore(tmp_path / "r.sqlite") as store:
        with pytest.raises(SweepError, match="cannot connect to dask scheduler nonsense"):
            run_sweep(planned(), store, SweepExecution("tasks:seeded", scheduler="nonsense"),
                      progress=False)


# ------------------------------------------------------------------ local workers


def test_local_workers_keep_their_object_and_share_the_work(tmp_path):
    """Two forked workers: every scenario once, each object's scenarios mostly on one worker."""
    items = planned("tasks:sleepy", masses=(0.1, 0.3, 0.5, 0.7), kinds=("pid", "lead_lag", "mpc"))
    with ResultStore(tmp_path / "r.sqlite") as store:
        summary = run_sweep(items, store, SweepExecution("tasks:sleepy", workers=2),
                            progress=False)
        rows = by_hash(store)
    assert (summary.ok, summary.failed) == (12, 0) and rows.keys() == {p.hash for p in items}
    workers = {}
    for p in items:
        assert rows[p.hash]["result"]["draw"] == tasks.seeded(p.scenario)["draw"]
        workers.setdefault(p.scenario.object.mass_kg, set()).add(rows[p.hash]["worker"])
    pids = {w.split(":")[1] for ws in workers.values() for w in ws}
    assert len(pids) == 2 and str(os.getpid()) not in pids  # two children of the driver
    # an object's scenarios go to the worker that ran it last; only the last one may be split
    assert sum(len(ws) == 1 for ws in workers.values()) >= 3, workers
