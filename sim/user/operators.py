"""Operator models (user kinds) and feedback modes by name.

========================  ===================================================
user kind                 operator model
========================  ===================================================
scripted                  follows the script, whatever the hand does
                          (:class:`sim.user.scripted.ScriptedOperator`)
reacting                  sees, feels and corrects
                          (:class:`sim.user.reacting.ReactingOperator`)
========================  ===================================================

========================  ===================================================
feedback mode             device and perception (:mod:`sim.user.feedback`)
========================  ===================================================
none                      vision only
force_vibration           grip force as a few vibration intensities
slip_vibration            a discrete burst at each slip event
touch                     an intact hand's touch (intact, ideal_interface)
========================  ===================================================

A new operator model is a class ``Model(params, feedback)`` satisfying
:class:`sim.user.operator.Operator`, a new feedback mode a class
``Mode(params)`` like :class:`sim.user.feedback.NoFeedback`. A model needs only
``name``, ``corrections``, ``correction_times``, ``start``, ``perceive``, ``intent`` and
``finish``: :func:`make_operator` completes the rest (:class:`CompletedOperator`: the
scripted user's arm, never done, no belief, no phases). Each registration is one call::

    register_operator("cautious", "mypackage.cautious:CautiousOperator")
    register_feedback("audio", "mypackage.audio:AudioFeedback")

Registrations by ``"module:attribute"`` are imported on first use, so the
scenario schema and the CLI list the names without importing the models.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from sim.errors import GriploopError
from sim.registry import Registry

if TYPE_CHECKING:
    from collections.abc import Callable

    from sim.user.operator import Operator, OperatorParams


class UnknownOperatorError(GriploopError, LookupError):
    """A user kind that is not registered; the message lists the registered ones."""


class UnknownFeedbackError(GriploopError, LookupError):
    """A feedback mode that is not registered; the message lists the registered ones."""


_OPERATORS = Registry("user kind", UnknownOperatorError)
_FEEDBACK = Registry("feedback mode", UnknownFeedbackError)


def register_operator(name: str, factory: Callable[..., Operator] | str, *,
                      takes_feedback: bool = True, replace: bool = False) -> None:
    """Register an operator model (a user kind).

    Parameters
    ----------
    name : str
        Name used by scenarios (``user.kind``) and the CLI (``--user``).
    factory : callable or str
        ``factory(params, feedback) -> Operator``, or its
        ``"package.module:attribute"`` reference.
    takes_feedback : bool
        Whether the model uses a feedback mode other than ``none``.
    replace : bool
        Allow replacing an existing registration.
    """
    _OPERATORS.register(name, factory, replace=replace, takes_feedback=bool(takes_feedback))


def register_feedback(name: str, factory: Callable[..., Any] | str, *,
                      replace: bool = False) -> None:
    """Register a feedback mode: ``factory(params) -> mode`` or its reference."""
    _FEEDBACK.register(name, factory, replace=replace)


unregister_operator, operator_names = _OPERATORS.functions(__name__, "operator")
unregister_feedback, feedback_names = _FEEDBACK.functions(__name__, "feedback")


def takes_feedback(name: str) -> bool:
    """Whether the user kind ``name`` uses feedback (raises for an unknown kind)."""
    return bool(_OPERATORS.info(name)["takes_feedback"])


def check_user(kind: str, feedback: str) -> None:
    """Refuse an unknown kind or mode, or feedback given to a kind that takes none.

    Raises
    ------
    UnknownOperatorError, UnknownFeedbackError
        Unknown name; the message lists the registered ones.
    sim.user.operator.OperatorError
        A feedback mode other than ``none`` for a user kind that takes none.
    """
    from sim.user.operator import OperatorError

    takes = takes_feedback(kind)
    if feedback not in _FEEDBACK:
        _FEEDBACK.entry(feedback)  # raises, listing the modes
    if not takes and feedback != "none":
        kinds = ", ".join(k for k in operator_names() if takes_feedback(k))
        raise OperatorError(
            f"feedback {feedback} needs a user kind that takes feedback ({kinds}); user "
            f"{kind} takes feedback none only")


def make_feedback(feedback: Any, params: OperatorParams | None = None) -> Any:
    """A feedback mode from its registered name (or ``feedback`` itself if not a name)."""
    if not isinstance(feedback, str):
        return feedback
    return _FEEDBACK.get(feedback)(params)


def make_operator(kind: str, *, feedback: str = "none",
                  params: OperatorParams | None = None) -> Operator:
    """An operator model of a registered kind with its feedback and parameters.

    A model without the optional members of :class:`sim.user.operator.Operator` comes
    back completed (:class:`CompletedOperator`).

    Raises
    ------
    UnknownOperatorError, UnknownFeedbackError, sim.user.operator.OperatorError
        See :func:`check_user`; also a model without one of :data:`REQUIRED_MEMBERS`.
    """
    check_user(kind, feedback)
    return complete_operator(_OPERATORS.get(kind)(params, feedback), kind, params)


#: What a registered operator model must have (:class:`sim.user.operator.Operator`).
REQUIRED_MEMBERS = ("start", "perceive", "intent", "finish")
#: What :class:`CompletedOperator` supplies when a model lacks it.
OPTIONAL_MEMBERS = ("wrist_move", "done", "belief", "phase_log", "reacts", "default_trial_s",
                    "open_intent")


def complete_operator(operator: Any, kind: str, params: OperatorParams | None = None) -> Any:
    """``operator`` itself when it has every member of the protocol, else completed.

    Raises
    ------
    sim.user.operator.OperatorError
        A member of :data:`REQUIRED_MEMBERS` is missing.
    """
    from sim.user.operator import OperatorError

    missing = [m for m in REQUIRED_MEMBERS if not callable(getattr(operator, m, None))]
    if missing:
        raise OperatorError(
            f"user kind {kind}: its model {type(operator).__name__} has no "
            f"{', '.join(missing)} (a user model defines {', '.join(REQUIRED_MEMBERS)})")
    if callable(getattr(operator, "wrist_move", None)) and all(
            hasattr(operator, m) for m in OPTIONAL_MEMBERS):
        return operator
    return CompletedOperator(operator, params)


def never_opens(n_samples: int) -> Any:
    """The open intent of a user who never opens: ``n_samples`` zeros (ndarray)."""
    import numpy as np

    return np.zeros(int(n_samples))


class CompletedOperator:
    """A registered model with the protocol's optional members supplied.

    Whatever the model has is its own; without ``wrist_move`` its arm is the scripted
    user's (:class:`sim.user.scripted.ScriptedArm`, watching the scenes it is given), and
    its trial lasts the scripted user's by default. It is never ``done`` before the
    trial's limit, has no ``belief`` and no phases, never opens (``open_intent`` zeros) and
    ``reacts`` (its sEMG is produced as it decides).
    """

    def __init__(self, inner: Any, params: OperatorParams | None = None) -> None:
        from sim.user.operator import PACED_TRIAL_S, OperatorParams
        from sim.user.scripted import SCRIPTED_TRIAL_S, ScriptedArm

        self.inner = inner
        self.arm = None if callable(getattr(inner, "wrist_move", None)) else ScriptedArm(
            (params or OperatorParams()).lift_s)
        defaults = {"done": False, "belief": None, "phase_log": [], "reacts": True,
                    "open_intent": never_opens,
                    "default_trial_s": SCRIPTED_TRIAL_S if self.arm is not None
                    else PACED_TRIAL_S}
        self._defaults = {k: v for k, v in defaults.items() if not hasattr(inner, k)}

    def __getattr__(self, name: str) -> Any:
        inner = self.__dict__["inner"]
        if hasattr(inner, name):
            return getattr(inner, name)
        defaults = self.__dict__["_defaults"]
        if name in defaults:
            return defaults[name]
        raise AttributeError(name)

    def start(self, plan: Any, *, control_dt_s: float, rng: Any) -> None:
        """The model's start; the scripted arm times its lift."""
        if self.arm is not None:
            self.arm.start(plan)
        self.inner.start(plan, control_dt_s=control_dt_s, rng=rng)

    def perceive(self, scene: Any) -> None:
        """The model perceives; the scripted arm watches for the established grip."""
        if self.arm is not None:
            self.arm.perceive(scene)
        self.inner.perceive(scene)

    def wrist_move(self) -> Any:
        """The model's arm move, or the scripted arm's."""
        return self.arm.wrist_move() if self.arm is not None else self.inner.wrist_move()


register_operator("reacting", "sim.user.reacting:ReactingOperator")
register_operator("scripted", "sim.user.scripted:ScriptedOperator", takes_feedback=False)
register_feedback("none", "sim.user.feedback:NoFeedback")
register_feedback("force_vibration", "sim.user.feedback:ForceVibration")
register_feedback("slip_vibration", "sim.user.feedback:SlipVibration")
register_feedback("touch", "sim.user.feedback:Touch")
