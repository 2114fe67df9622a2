"""What ``griploop eggs``, ``slip-recovery``, ``force-matching`` and ``transfers`` share.

Each command takes its sweep from the library file of its kind
(``scenarios/library/eggs.yaml``, ``slip_recovery.yaml``, ``force_matching.yaml``),
applies the options (controller, estimator, user, feedback modes, subjects,
seed and the task's own), runs it with :func:`scenarios.execution.sweep.run_sweep`
on local workers into a results store (a temporary one unless ``--db`` is
given, which makes the run resumable and reportable), and prints and writes
the comparison of the feedback modes (:mod:`scenarios.runners.feedback_tasks`).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
import tempfile
from collections.abc import Callable, Mapping
from importlib.resources import files
from pathlib import Path
from typing import Any

import yaml

from scenarios.cli.choices import (
    add_hand_options,
    add_practice_window_options,
    add_user_options,
    check_choice,
    check_hand_options,
    check_practice_window,
    check_user_options,
    controller_names,
    estimator_choices,
    one_of,
)
from scenarios.cli.errors import UsageError
from scenarios.schema.names import IDEAL_INTERFACE, INTACT


def add_common_options(p: argparse.ArgumentParser, *, default_feedback: str,
                       default_subjects: int) -> None:
    """The options every feedback benchmark takes."""
    p.add_argument("--controller", required=True, metavar="NAME", help=one_of(controller_names()))
    p.add_argument("--estimator", required=True, metavar="NAME", help=one_of(estimator_choices()))
    p.add_argument("--mode", default="free_run", metavar="MODE",
                   help="estimator mode: free_run (sEMG only, default) or one_step")
    add_user_options(p, feedback_list=True, default_feedback=default_feedback)
    p.add_argument("--subjects", type=int, default=default_subjects, metavar="N",
                   help=f"virtual subjects 1..N (default {default_subjects})")
    p.add_argument("--population-seed", type=int, default=0,
                   help="seed of the virtual population (default 0)")
    p.add_argument("--seed", type=int, default=None, metavar="S",
                   help="sweep seed: every scenario's seed derives from it (default: the "
                   "library file's)")
    p.add_argument("--workers", type=int, default=1, metavar="N",
                   help="worker processes forked from this one (default 1)")
    p.add_argument("--db", type=Path, default=None, metavar="PATH",
                   help="results store (resumable; default: a temporary one, discarded)")
    add_practice_window_options(p)
    add_hand_options(p, paradigm_list=True)
    p.add_argument("--intact", action="store_true",
                   help="also run the two references driven by the user's own force (no sEMG "
                   "path, felt by touch) on the same subjects and seeds: the intact hand "
                   "(human speed, grip coupled to load; the JSON's intact) and the "
                   "prosthesis's hand (the JSON's ideal_interface)")
    p.add_argument("--vision", default="on", metavar="on|off",
                   help="off: the user sees neither the hand nor the object in the measured "
                   "trials, and hears the hand's motor (default on)")
    p.add_argument("--json", type=Path, default=None, metavar="FILE", help="also write JSON here")
    p.add_argument("--no-progress", action="store_true", help="do not draw the progress bar")


def comma_list(option: str, text: str, convert: Callable[[str], Any] = str) -> list[Any]:
    """A comma-separated option as a list (``UsageError`` if empty or unparsable)."""
    items = [t.strip() for t in text.split(",") if t.strip()]
    if not items:
        raise UsageError(f"{option}: expected a comma-separated list, found {text!r}")
    try:
        return [convert(t) for t in items]
    except ValueError:
        raise UsageError(f"{option}: expected comma-separated numbers, found {text!r}") from None


def library_sweep(kind: str) -> dict[str, Any]:
    """The library sweep file of a task kind, as a mapping."""
    text = (files("scenarios") / "library" / f"{kind}.yaml").read_text()
    return yaml.safe_load(text)


def run_task(args: argparse.Namespace, kind: str, *, base: Mapping[str, Any] | None = None,
             grid: Mapping[str, list[Any]] | None = None,
             table: Callable[[dict[str, Any]], str], feedback_grid: bool = True) -> int:
    """Run a benchmark as the options say; print ``table(result)``, write the JSON.

    With ``--intact`` the same design also runs with the two references the user's own
    force drives (:func:`reference_arms`: feedback ``touch``, no sEMG path, paradigm
    ``force``), into the same store: the intact hand (estimator ``intact``, the JSON's
    ``intact``) and the prosthesis's hand (``ideal_interface``, the JSON's
    ``ideal_interface``). With several ``--paradigm`` entries they run on the same subjects and
    seeds; the JSON's top level is the first paradigm's and ``by_paradigm`` holds each
    one's, in the same form.

    Parameters
    ----------
    kind : str
        Scenario kind (``eggs``, ``slip_recovery``, ``force_matching``, ``transfers``).
    base : mapping, optional
        Dotted scenario paths set on the library file's base.
    grid : mapping, optional
        Dotted scenario paths swept, added to the subjects and feedback modes.
    feedback_grid : bool
        Sweep the ``--feedback`` modes (a benchmark that compares them).
    """
    from scenarios.feedback_summary import aggregate

    feedback, paradigms = _checked_lists(args)
    settings = {"controller.kind": args.controller, "estimator.name": args.estimator,
                "estimator.mode": args.mode, "estimator.window_ms": args.window_ms,
                "estimator.step_ms": args.step_ms, "user.kind": args.user,
                "user.practice": args.practice, "user.vision": args.vision == "on",
                "subject.population_seed": args.population_seed, **(base or {}),
                **hand_settings(args.drive, args.auto_grip, args.decoder)}
    arms = [(settings, feedback, {**(grid or {}), **paradigm_grid(paradigms)})]
    references = reference_arms(settings, grid) if getattr(args, "intact", False) else []
    arms.extend(arm for _, arm in references)
    with tempfile.TemporaryDirectory() as tmp:
        db = args.db if args.db is not None else Path(tmp) / "results.sqlite"
        outcomes = [_run_arm(args, kind, arm, modes, arm_grid, feedback_grid, db)
                    for arm, modes, arm_grid in arms]
    (spec, ok, failed, elapsed) = outcomes[0]
    by_paradigm = {p: aggregate(kind, [r for r in ok if r.get("paradigm", "force") == p])
                   for p in paradigms}
    result = {**by_paradigm[paradigms[0]],
              "settings": {"kind": kind, **settings, "feedback": feedback,
                           "paradigm": paradigms, "drive": args.drive,
                           "auto_grip": args.auto_grip, "decoder": args.decoder,
                           "subjects": args.subjects,
                           "seed": spec.seed, **{k: v for k, v in (grid or {}).items()}},
              "scenarios": {"ok": len(ok), "failed": len(failed)}}
    if len(paradigms) > 1:
        result["by_paradigm"] = by_paradigm
    for (key, _), (_, ref_ok, ref_failed, _) in zip(references, outcomes[1:], strict=True):
        result[key] = aggregate(kind, ref_ok)
        result["scenarios"][key] = {"ok": len(ref_ok), "failed": len(ref_failed)}
        failed = failed + ref_failed
    print(f"{kind}: {len(ok)} scenarios ok, {len(outcomes[0][2])} failed in {elapsed:.1f} s "
          f"({args.controller}, {args.estimator} {args.mode}, {args.user} user, practice "
          f"{args.practice}, window {args.window_ms:g}/{args.step_ms:g} ms, "
          f"{args.subjects} subjects)")
    for paradigm in paradigms:
        if len(paradigms) > 1:
            print(f"paradigm {paradigm}:")
        print(table({**result, **by_paradigm[paradigm]}))
    for r in failed[:3]:
        print(f"failed: {(r.get('error') or '').splitlines()[0] if r.get('error') else r['hash']}",
              file=sys.stderr)
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(result, indent=1))
        print(f"wrote {args.json}")
    if args.db is not None:
        print(f"results in {args.db} (sweep {spec.name}; griploop report {args.db} --out DIR)")
    return 0


def _checked_lists(args: argparse.Namespace) -> tuple[list[str], list[str]]:
    """The ``--feedback`` and ``--paradigm`` lists, once every common option is checked.

    Raises
    ------
    UsageError
        The first option out of its choices or range, named in one line.
    """
    feedback = comma_list("--feedback", args.feedback)
    paradigms = comma_list("--paradigm", args.paradigm)
    check_user_options(args.user, feedback)
    check_hand_options(paradigms, args.drive, args.decoder)
    check_choice("--controller", args.controller, controller_names())
    check_choice("--estimator", args.estimator, estimator_choices())
    check_practice_window(args.practice, args.window_ms, args.step_ms)
    if args.mode not in ("free_run", "one_step"):
        raise UsageError(f"--mode: expected free_run or one_step, found {args.mode!r}")
    if args.vision not in ("on", "off"):
        raise UsageError(f"--vision: expected on or off, found {args.vision!r}")
    if args.subjects < 1:
        raise UsageError(f"--subjects: expected at least 1, found {args.subjects}")
    if args.workers < 1:
        raise UsageError(f"--workers: expected at least 1, found {args.workers}")
    return feedback, paradigms


def reference_arms(settings: Mapping[str, Any], grid: Mapping[str, list[Any]] | None
                   ) -> list[tuple[str, tuple[dict[str, Any], list[str],
                                              Mapping[str, list[Any]] | None]]]:
    """``--intact``'s arms, ``(JSON key, (settings, feedback modes, grid))``: the intact hand
    and the ideal interface, felt by touch, on the benchmark's subjects and seeds.

    Neither has sEMG to decode; the intact hand has no drive or slip response of its own
    (its digits are a person's, :mod:`sim.hand.human`), the ideal interface keeps the
    prosthesis's (the intact-hand reference of before issue 37, unchanged).
    """
    own = {k: v for k, v in settings.items() if k != "decoder"}
    human = {k: v for k, v in own.items() if k not in ("hand.drive", "auto_grip")}
    return [(key, ({**arm, "estimator.name": key, "user.kind": "reacting"}, ["touch"], grid))
            for key, arm in ((INTACT, human), (IDEAL_INTERFACE, own))]


def hand_settings(drive: str, auto_grip: bool, decoder: str | None = None) -> dict[str, Any]:
    """The hand's settings as scenario paths, left out at their defaults (no seed moves)."""
    return {**({} if drive == "backdrivable" else {"hand.drive": drive}),
            **({"auto_grip": True} if auto_grip else {}),
            **({} if decoder is None else {"decoder": decoder})}


def paradigm_grid(paradigms: list[str]) -> dict[str, list[str]]:
    """The paradigms as a grid of the sweep (none for the default alone)."""
    return {} if paradigms == ["force"] else {"paradigm": paradigms}


def _run_arm(args: argparse.Namespace, kind: str, settings: Mapping[str, Any],
             feedback: list[str], grid: Mapping[str, list[Any]] | None, feedback_grid: bool,
             db: Path) -> tuple[Any, list[dict[str, Any]], list[dict[str, Any]], float]:
    """One sweep of the library design with ``settings``; its spec, ok and failed rows."""
    from scenarios.execution.sweep import SweepExecution, run_sweep
    from scenarios.schema import iter_expanded, parse_sweep
    from scenarios.store import ResultStore

    data = library_sweep(kind)
    for path, value in settings.items():
        _set(data["base"], path, value)
    data["grid"] = {"subject.subject_id": list(range(1, args.subjects + 1)), **(grid or {})}
    if feedback_grid or len(feedback) > 1:
        data["grid"]["user.feedback"] = feedback
    else:
        _set(data["base"], "user.feedback", feedback[0])
    if args.seed is not None:
        data["seed"] = args.seed
    digest = hashlib.sha256(json.dumps(data, sort_keys=True).encode()).hexdigest()[:10]
    data["name"] = f"{kind}-{digest}"
    spec = parse_sweep(data, source=f"griploop {args.command} options")
    with ResultStore(db) as store:
        summary = run_sweep(list(_planned(spec, iter_expanded)), store,
                            SweepExecution(workers=args.workers, time_limit_s=spec.time_limit_s),
                            sweep_name=spec.name, progress=not args.no_progress)
        rows = store.rows(sweep=spec.name)
    ok = [r["result"] for r in rows if r["status"] == "ok"]
    failed = [r for r in rows if r["status"] == "failed"]
    return spec, ok, failed, summary.elapsed_s


def _planned(spec: Any, iter_expanded: Callable[..., Any]) -> Any:
    from scenarios.execution.sweep import iter_plan

    return iter_plan(iter_expanded(spec, spec.name))


def _set(node: dict[str, Any], path: str, value: Any) -> None:
    parts = path.split(".")
    for part in parts[:-1]:
        node = node.setdefault(part, {})
    node[parts[-1]] = value


def fmt(value: float | None, spec: str = ".2f", scale: float = 1.0) -> str:
    """A number for a table (``-`` for None)."""
    return "-" if value is None else format(value * scale, spec)


def ci_text(ci: list[float | None] | None, spec: str = ".2f", scale: float = 1.0) -> str:
    """``[lo, hi]`` for a table."""
    if not ci or ci[0] is None:
        return "-"
    return f"[{fmt(ci[0], spec, scale)}, {fmt(ci[1], spec, scale)}]"


def with_intact(result: Mapping[str, Any], key: str = "by_feedback") -> dict[str, Any]:
    """``result[key]`` per feedback mode, then (with ``--intact``) the intact hand's and the
    ideal interface's as ``"intact (touch)"`` and ``"ideal_interface (touch)"``: the rows a
    table prints."""
    rows = dict(result[key])
    for reference in (INTACT, IDEAL_INTERFACE):
        for mode, value in result.get(reference, {}).get(key, {}).items():
            rows[f"{reference} ({mode})"] = value
    return rows
