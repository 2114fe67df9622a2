"""Practice before the measured trials: the user learns their prosthesis, once per interface.

Every study of prosthesis users measures them after they have familiarised themselves
with the device (CALIBRATION.md, "Practised users"). :func:`practised_belief` runs
``n_lifts`` practice lifts of the object class's library object with the same calibrated
estimator, the same controller and the same feedback, by a user of the same kind and
parameters, and returns what they learnt (:class:`sim.user.belief.ProsthesisBelief`: how
hard to contract for this prosthesis, and the safety margin its variability calls for).

Practice is deterministic for its seed and cached on disk per subject and interface
(``$GRIPLOOP_CACHE_DIR/practice``, JSON), so a sweep's scenarios of one subject and one
interface practise once: the key holds the subject, the calibration (estimator, options,
mode, order, session seed, identification fraction, window), the controller and its
specification, the object class, the user kind, feedback and parameters, the number of
lifts, the practice seed, the trial's limits and the digest of every source file the
practice runs through. A file that does not parse, or whose key differs, is rebuilt and
replaced, never trusted; an unwritable cache directory is a warning
(:class:`sim.cache.CacheNotWritableWarning`), and the user practises again next time.
"""

from __future__ import annotations

import functools
import hashlib
import json
import sys
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from controllers.design_cache import grasp_design
from scenarios.runners.calibration import Calibration, CalibrationSettings
from scenarios.runners.reference import grasp_task
from scenarios.runners.trial import TrialSetup, run_trial
from scenarios.runners.trial_loop import DEFAULT_HAND, HandSettings
from sim import cache as sim_cache
from sim.hand.objects import ObjectSpec, make_object, object_names
from sim.user.belief import ProsthesisBelief
from sim.user.operator import OperatorParams
from sim.user.operators import make_operator
from sim.user.subjects import VirtualSubject

DEFAULT_PRACTICE = 5
"""Practice lifts before the measured trials (``--practice``)."""
MAX_PRACTICE = 50
"""The most practice lifts a scenario may ask for."""
PRACTICE_HOLD_S = 1.0
"""How long a practice lift holds the object in the air, s."""
FORMAT = 1


@dataclass(frozen=True)
class Interface:
    """What the user practises with: everything but the measured object's own settings.

    Attributes
    ----------
    calibration : CalibrationSettings
        How the estimator was calibrated (estimator, mode, window, ...).
    controller : str
        Controller kind.
    controller_spec : mapping
        Its flat design specification (:meth:`~controllers.design_spec.DesignSpec.from_mapping`).
    practice_object : ObjectSpec
        The object practised with: the library object of the measured object's
        class (:func:`practice_object_for`).
    user, feedback : str
        User kind and feedback mode.
    params : OperatorParams
        The user's parameters.
    control_dt_s, hand_force_at_mvc_n : float
        Control period, s, and the hand force at the user's MVC, N.
    hand : HandSettings
        The hand's drive, paradigm and slip response: what the user learns to use (how
        hard to contract under ``force_hold``, how far to trust a hand that holds).
    """

    calibration: CalibrationSettings
    controller: str
    controller_spec: Mapping[str, Any]
    practice_object: ObjectSpec
    user: str
    feedback: str
    params: OperatorParams
    control_dt_s: float
    hand_force_at_mvc_n: float
    hand: HandSettings = DEFAULT_HAND


def practice_object_for(obj: ObjectSpec) -> ObjectSpec:
    """The object a user practises with before grasping ``obj``: its class's library object.

    A can of any mass and friction is practised with the library can; an object whose
    name is not registered is practised with itself.
    """
    return make_object(obj.name) if obj.name in object_names() else obj


def practised_belief(subject: VirtualSubject, cal: Calibration, interface: Interface, *,
                     cal_seq: np.random.SeedSequence, n_lifts: int,
                     seed_seq: np.random.SeedSequence, trial_s: float) -> ProsthesisBelief:
    """What ``subject`` believes of their prosthesis after ``n_lifts`` practice lifts.

    Parameters
    ----------
    cal : Calibration
        The fitted estimator the user practises with.
    interface : Interface
        The rest of what they practise with.
    cal_seq : SeedSequence
        The seed ``cal`` was fitted with (for the cache's key).
    n_lifts : int
        Practice lifts (0: a novice's belief).
    seed_seq : SeedSequence
        Seeds the practice lifts' sEMG, hand and perception.
    trial_s : float
        Time limit of one practice lift, s.

    Raises
    ------
    DivergedError
        The physics diverged in a practice lift.
    """
    operator = make_operator(interface.user, feedback=interface.feedback,
                             params=interface.params)
    novice = operator.belief
    if n_lifts <= 0 or novice is None:
        return novice if novice is not None else ProsthesisBelief.novice(interface.params)
    key = _key(subject, interface, n_lifts, seed_seq, trial_s, interface.calibration.key(cal_seq))
    directory = sim_cache.cache_subdir("practice")
    path = None if directory is None else directory / f"{key[:24]}.json"
    belief, _ = sim_cache.cached(
        path, lambda p: _read(p, key),
        lambda: _practise(subject, cal, interface, operator, n_lifts, seed_seq, trial_s),
        lambda p, b: sim_cache.write_atomic(p, json.dumps(
            {"format": FORMAT, "key": key, "belief": b.to_dict()}).encode()))
    return belief


def practise(operator: Any, subject: VirtualSubject, cal: Calibration, interface: Interface, *,
             cal_seq: np.random.SeedSequence, n_lifts: int,
             seed_seq: np.random.SeedSequence) -> int:
    """Give ``operator`` (a user who learns) the belief ``n_lifts`` of practice leave.

    :func:`practised_belief` with the trial limit of the user's kind; a user without a
    belief (one who does not learn) is left as is. Returns the practice lifts the user
    learnt from (0 for one who does not learn).
    """
    if operator.belief is None or n_lifts <= 0:
        return 0
    operator.belief = practised_belief(subject, cal, interface, cal_seq=cal_seq,
                                       n_lifts=n_lifts, seed_seq=seed_seq,
                                       trial_s=float(operator.default_trial_s))
    return int(n_lifts)


def _practise(subject: VirtualSubject, cal: Calibration, interface: Interface, operator: Any,
              n_lifts: int, seed_seq: np.random.SeedSequence, trial_s: float
              ) -> ProsthesisBelief:
    """Run the practice lifts; the operator's belief after them."""
    obj = interface.practice_object
    design = grasp_design(obj, interface.controller, interface.control_dt_s,
                          interface.hand.controller_spec(interface.controller_spec))
    c = interface.calibration
    setup = TrialSetup(subject, obj, cal, design, c.generator, interface.control_dt_s,
                       interface.hand_force_at_mvc_n, c.window_ms, c.step_ms, interface.hand)
    task = grasp_task(obj, hold_s=PRACTICE_HOLD_S, limit_s=trial_s)
    for seqs in seed_seq.spawn(n_lifts):
        trial = run_trial(setup, operator, task, tuple(seqs.spawn(3)))
        trial.raise_if_diverged("practice lift: ")
    return operator.belief


def _read(path: Any, key: str) -> ProsthesisBelief | None:
    """The belief stored at ``path`` under ``key``; None when absent, stale or corrupt."""
    try:
        data = json.loads(path.read_bytes())
        if data.get("format") != FORMAT or data.get("key") != key:
            return None
        return ProsthesisBelief.from_dict(data["belief"])
    except (OSError, ValueError, TypeError, KeyError, AttributeError):
        return None


@functools.cache
def _source_digest() -> str:
    """Every source file a practice lift runs through."""
    return sim_cache.source_digest(("sim", "estimation", "controllers", "scenarios.runners"))


def _key(subject: VirtualSubject, interface: Interface, n_lifts: int,
         seed_seq: np.random.SeedSequence, trial_s: float,
         calibration_key: Mapping[str, Any]) -> str:
    """SHA-256 of everything a practice depends on (module notes)."""
    with np.printoptions(threshold=sys.maxsize, precision=17):
        who = repr(subject)
    body = {
        "subject": hashlib.sha256(who.encode()).hexdigest(),
        "calibration": {k: _jsonable(v) for k, v in sorted(calibration_key.items())},
        "interface": {**{k: _jsonable(getattr(interface, k)) for k in (
            "controller", "user", "feedback", "control_dt_s", "hand_force_at_mvc_n")},
            "practice_object": repr(interface.practice_object),
            "controller_spec": _jsonable(dict(interface.controller_spec)),
            "params": interface.params.to_dict(),
            **({} if interface.hand == DEFAULT_HAND else {"hand": interface.hand.fields()})},
        "n_lifts": int(n_lifts), "trial_s": float(trial_s),
        "seed": [int(x) for x in seed_seq.generate_state(4)],
        "source": _source_digest(), "format": FORMAT,
    }
    return hashlib.sha256(json.dumps(body, sort_keys=True, default=repr).encode()).hexdigest()


def _jsonable(value: Any) -> Any:
    if isinstance(value, Mapping):
        return {str(k): _jsonable(v) for k, v in sorted(value.items(), key=lambda kv: str(kv[0]))}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, (np.floating, np.integer)):
        return value.item()
    return value
