"""How well each open/close decoder reads each virtual subject: the decoders' study.

A decoder (:mod:`estimation.decoding`) is fitted as a virtual subject's calibration fits it
(:func:`scenarios.runners.calibration.fit_decoder`: the paper's squeezes and a session of
open contractions, :meth:`sim.user.subjects.VirtualSubject.open_session`) and judged on a
second pair of sessions of the same subject, recorded with other seeds: the squeezes of a
new paper session and new open contractions. Per subject and decoder:

==========================  ==============================================================
column                      meaning
==========================  ==============================================================
``flexor_extensor_ratio``   the subject's squeeze co-contraction: RMS of channels 6-8 over
                            channels 3-5 in the active windows of the judged squeezes
                            (:mod:`sim.user.emg_stats`; real subjects 1.0 [0.36-1.19])
``unrequested_opens_pct``   squeeze windows (close intent, no open intent) decoded as open
``unrequested_closes_pct``  rest windows decoded as close
``opens_found_pct``         open windows decoded as open
``closes_found_pct``        squeeze windows decoded as close
==========================  ==============================================================

The decoder never sees the judged sessions before it decodes them. Subjects come from the
default population and from ``extensor_dominant`` (:mod:`sim.user.populations`), whose
squeezes look like the real recordings' most extensor-dominant subjects.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from scenarios.runners.calibration import fit_decoder
from sim.errors import GriploopError
from sim.user.emg_stats import recording_statistics
from sim.user.subjects import VirtualSubject, make_population

#: The columns of a study row, in order.
STUDY_COLUMNS = ("variant", "subject_id", "flexor_extensor_ratio", "decoder",
                 "unrequested_opens_pct", "unrequested_closes_pct", "opens_found_pct",
                 "closes_found_pct", "squeeze_windows", "rest_windows", "open_windows", "error")


@dataclass(frozen=True)
class DecoderStudy:
    """Which subjects and decoders the study runs.

    Attributes
    ----------
    subjects : int
        Subjects per population variant.
    seed : int
        The population's seed (and the sessions' root seed).
    variants : tuple of str
        Population variants (:func:`sim.user.populations.population_names`).
    decoders : tuple of str
        Decoders (:func:`estimation.decoding.decoder_names`).
    generator : str
        The sEMG generator.
    """

    subjects: int = 10
    seed: int = 0
    variants: tuple[str, ...] = ("default", "extensor_dominant")
    decoders: tuple[str, ...] = ("two_site", "pattern")
    generator: str = "noise"


def _pct(hits: np.ndarray, among: np.ndarray) -> float | None:
    n = int(np.sum(among))
    return None if n == 0 else 100.0 * float(np.sum(hits & among)) / n


def judge_subject(subject: VirtualSubject, study: DecoderStudy, variant: str) -> list[dict]:
    """The study's rows of one subject: one per decoder (module notes)."""
    from estimation.decoding import decoder_windows

    root = np.random.SeedSequence(int(study.seed), spawn_key=(int(subject.subject_id), 36))
    cal_squeeze, cal_open, test_squeeze, test_open = (np.random.default_rng(s)
                                                      for s in root.spawn(4))
    gen = study.generator
    calibration = [subject.paper_session(cal_squeeze, generator=gen),
                   subject.open_session(cal_open, generator=gen)]
    judged = [subject.paper_session(test_squeeze, generator=gen),
              subject.open_session(test_open, generator=gen)]
    ratio = float(recording_statistics(judged[0])["flexor_extensor_ratio"])
    xs, ys = [], []
    for rec in judged:
        x, y = decoder_windows(rec.emg, rec.intent, rec.open_intent, fs_hz=rec.fs_hz)[:2]
        xs.append(x)
        ys.append(y)
    x, y = np.concatenate(xs), np.concatenate(ys)
    rest, close, open_ = y == 0, y == 1, y == 2
    rows = []
    for name in study.decoders:
        row: dict[str, Any] = dict.fromkeys(STUDY_COLUMNS)
        row.update(variant=variant, subject_id=int(subject.subject_id),
                   flexor_extensor_ratio=ratio, decoder=name,
                   squeeze_windows=int(close.sum()), rest_windows=int(rest.sum()),
                   open_windows=int(open_.sum()))
        try:
            decoded = fit_decoder(name, calibration).decode(x)
        except GriploopError as exc:
            row["error"] = str(exc).splitlines()[0]
            rows.append(row)
            continue
        says_close, says_open = decoded[:, 0] > 0.0, decoded[:, 1] > 0.0
        row.update(unrequested_opens_pct=_pct(says_open, close),
                   unrequested_closes_pct=_pct(says_close, rest),
                   opens_found_pct=_pct(says_open, open_),
                   closes_found_pct=_pct(says_close, close))
        rows.append(row)
    return rows


def run_study(study: DecoderStudy = DecoderStudy()) -> list[dict]:
    """Every subject's rows, variant by variant (module notes)."""
    rows: list[dict] = []
    for variant in study.variants:
        for subject in make_population(study.subjects, study.seed, variant=variant):
            rows.extend(judge_subject(subject, study, variant))
    return rows


def summarize(rows: Sequence[dict]) -> dict[str, dict[str, Any]]:
    """Per decoder: the worst and the median subject's unrequested opens and closes, the
    median opens and closes found, and the subjects it could not be fitted for."""
    out: dict[str, dict[str, Any]] = {}
    for name in dict.fromkeys(r["decoder"] for r in rows):
        mine = [r for r in rows if r["decoder"] == name]
        ok = [r for r in mine if r["error"] is None]

        def stat(key: str, how: Any, ok: list = ok) -> float | None:
            values = [r[key] for r in ok if r[key] is not None]
            return float(how(values)) if values else None

        out[name] = {"subjects": len(mine), "failed": len(mine) - len(ok),
                     "worst_unrequested_opens_pct": stat("unrequested_opens_pct", np.max),
                     "median_unrequested_opens_pct": stat("unrequested_opens_pct", np.median),
                     "worst_unrequested_closes_pct": stat("unrequested_closes_pct", np.max),
                     "median_unrequested_closes_pct": stat("unrequested_closes_pct", np.median),
                     "median_opens_found_pct": stat("opens_found_pct", np.median),
                     "median_closes_found_pct": stat("closes_found_pct", np.median)}
    return out


def preferred_decoder(rows: Sequence[dict]) -> str:
    """The decoder with the fewer unrequested opens over the study's subjects (its worst
    subject first, then its median; a decoder that failed for any subject loses)."""
    summary = summarize(rows)

    def rank(name: str) -> tuple:
        s = summary[name]
        return (s["failed"], s["worst_unrequested_opens_pct"] or 0.0,
                s["median_unrequested_opens_pct"] or 0.0)

    return min(summary, key=rank)


class GivenIntents:
    """A user whose close and open intents are given sample by sample, who never moves the
    arm (a mechanism's measurement: no decision in it).

    Parameters
    ----------
    close, open_ : ndarray, shape (n_samples,)
        The close and open intents, 0..1, at the plan's rate.
    """

    name = "given_intents"
    reacts = True
    belief = None
    done = False

    def __init__(self, close: np.ndarray, open_: np.ndarray) -> None:
        self.close = np.asarray(close, dtype=float)
        self.open = np.asarray(open_, dtype=float)
        self.default_trial_s = 0.0
        self.corrections = 0
        self.correction_times: list[float] = []
        self.phase_log: list[tuple[float, str]] = []
        self._n = 0

    def start(self, plan: Any, *, control_dt_s: float, rng: np.random.Generator) -> None:
        """From the first sample."""
        self._n = 0

    def perceive(self, scene: Any) -> None:
        """Nothing to decide."""

    def intent(self, n_samples: int) -> np.ndarray:
        """The next ``n_samples`` of close intent."""
        i0 = self._n
        self._n = i0 + n_samples
        return self.close[i0:self._n]

    def open_intent(self, n_samples: int) -> np.ndarray:
        """The open intent of the samples the last :meth:`intent` gave."""
        return self.open[self._n - n_samples:self._n]

    def wrist_move(self) -> None:
        """The arm stays."""
        return None

    def finish(self) -> Any:
        """Nothing learnt."""
        from sim.user.operator import TrialMemory

        return TrialMemory(0.0, 0.0)


@dataclass(frozen=True)
class OpeningTest:
    """A squeeze, a rest with the hand holding, then an opening contraction.

    Attributes
    ----------
    squeeze_level : float
        The close intent of the squeeze (fraction of MVC).
    open_level : float
        The open intent (1: full effort).
    squeeze_s, rest_s, open_s : float
        When the squeeze ends, when the opening begins and when the trial ends, s.
    rise_s : float
        Each contraction's rise and fall, s.
    """

    squeeze_level: float = 0.5
    open_level: float = 1.0
    squeeze_s: float = 3.0
    rest_s: float = 4.0
    open_s: float = 6.5
    rise_s: float = 0.2

    def intents(self, fs_hz: float) -> tuple[np.ndarray, np.ndarray]:
        """The close and open intents, each shape (n_samples,)."""
        t = np.arange(int(round(self.open_s * fs_hz))) / fs_hz

        def pulse(level: float, t0: float, t1: float) -> np.ndarray:
            up = np.clip((t - t0) / self.rise_s, 0.0, 1.0)
            down = np.clip((t1 - t) / self.rise_s, 0.0, 1.0)
            return level * np.minimum(up, down)

        return pulse(self.squeeze_level, 1.0, self.squeeze_s), \
            pulse(self.open_level, self.rest_s, self.open_s + 1.0)


def opening_time_s(setup: Any, test: OpeningTest = OpeningTest(), *, seed: int = 0
                   ) -> dict[str, float | None]:
    """How long the open intent takes to open the hand closed on ``setup.obj``.

    The user squeezes (the hand closes on the object on the table), relaxes (the hand holds)
    and contracts to open at ``test.open_level``. The hand is fully open once its digits are
    back within 5 % of their travel from where they started.

    Parameters
    ----------
    setup : scenarios.runners.trial.TrialSetup
        The user, their calibration (with a decoder), the controller and the hand.
    test : OpeningTest
    seed : int
        Seeds the sEMG session and the hand.

    Returns
    -------
    dict
        ``open_s`` (from the opening contraction's onset to fully open, s; ``None`` if the
        hand did not open), ``closed_travel_rad`` (how far the digits had closed) and
        ``held_grip_n`` (the grip while the user rested).
    """
    from scenarios.runners.person import VirtualPerson
    from scenarios.runners.trial_loop import TrialLoop, TrialTiming
    from sim.user.operator import Plan

    fs_hz = 200.0
    close, open_ = test.intents(fs_hz)
    plan = Plan(intent=close, fs_hz=fs_hz, hold_level=test.squeeze_level, goal_n=1.0,
                force_range_n=setup.hand_force_at_mvc_n, lift_height_m=None,
                open_to_release=True)
    seqs = np.random.SeedSequence(int(seed)).spawn(2)
    person = VirtualPerson(setup, GivenIntents(close, open_), plan,
                           session_rng=np.random.default_rng(seqs[0]),
                           operator_rng=np.random.default_rng(0))
    loop = TrialLoop(setup.obj, setup.design, person,
                     TrialTiming(test.open_s, setup.control_dt_s), lift_height_m=None,
                     seed=int(seqs[1].generate_state(1)[0]), hand=setup.hand)
    positions, grips = [], []
    try:
        start = loop.reset()["finger_position_rad"]
        while not loop.step():
            positions.append(loop.info["finger_position_rad"])
            grips.append(loop.info["grip_force_n"])
    finally:
        loop.env.close()
    t = (np.arange(len(positions)) + 1) * loop.dt
    pos = np.asarray(positions)
    before = t < test.rest_s
    closed = float(pos[before][-1])
    travel = closed - start
    held = float(np.mean(np.asarray(grips)[(t > test.rest_s - 0.5) & before]))
    opened = np.flatnonzero((t >= test.rest_s) & (np.abs(pos - start) <= 0.05 * abs(travel)))
    return {"open_s": float(t[opened[0]] - test.rest_s) if opened.size else None,
            "closed_travel_rad": float(travel), "held_grip_n": held}
