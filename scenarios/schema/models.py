"""Pydantic models of a scenario (the sweep file's models: :mod:`scenarios.schema.sweep_file`).

Names of the extensible families are checked against their registries when a
scenario is validated (:mod:`scenarios.schema.names`). Module attributes
``ESTIMATORS``, ``OBJECTS``, ``GENERATORS``, ``CONTROLLERS`` and
``SCENARIO_KINDS`` give the names registered at the time they are read.
"""

from __future__ import annotations

import json
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from scenarios.schema.canonical import added_field, omit_added_defaults  # noqa: F401
from scenarios.schema.names import (  # noqa: F401  (re-exported: the schema's public names)
    INTACT,
    NO_ESTIMATOR,
    ORACLE,
    PRACTICE_RANGE,
    REGISTRY_LISTS,
    STEP_RANGE_MS,
    WINDOW_RANGE_MS,
    check_declared_options,
    check_registered,
    controller_names,
    controller_own_options,
    decoder_names,
    drive_names,
    estimator_choices,
    estimator_own_options,
    feedback_modes,
    generator_names,
    kind_protocols,
    object_names,
    paradigm_names,
    scenario_kinds,
    user_kinds,
)
from sim.errors import GriploopError

SIZE_LENGTHS = {"sphere": 1, "cylinder": 2, "box": 3}
#: The largest seed a scenario or sweep may give (numpy's SeedSequence takes any int).
MAX_SEED = 2**63 - 1
DEFAULT_TIME_LIMIT_S = 120.0
"""Default per-scenario time limit, s: 100x a typical episode (1 s), 10x a slow one."""


def __getattr__(attr: str) -> Any:
    if attr in REGISTRY_LISTS:  # the names registered at the time of reading
        return REGISTRY_LISTS[attr]()
    raise AttributeError(f"module {__name__!r} has no attribute {attr!r}")


class ScenarioError(GriploopError, ValueError):
    """A scenario or sweep file is malformed, has unknown keys or bad values."""


class StrictModel(BaseModel):
    """Base of every scenario section: unknown fields, NaN and inf are refused."""
    model_config = ConfigDict(extra="forbid", validate_default=True, allow_inf_nan=False)


class SubjectConfig(StrictModel):
    """The virtual subject wearing the armband.

    Attributes
    ----------
    population_seed : int
        Seed of the virtual population the subject is drawn from.
    subject_id : int
        Number of the subject within the population, from 1 (the paper has
        10; ``sim.user.subjects.make_population`` numbers them 1..n).
    generator : str
        sEMG generator registered in :mod:`sim.user.generators`: ``noise``
        (amplitude-modulated noise, Hogan and Mann 1980), ``motor_units`` (a
        Fuglevand (1993) motor-unit pool), ...
    extra_noise_lsb : float
        Additional sEMG noise std in int8 counts, added in quadrature to the
        rest noise (about 1.9 LSB); ``sim.user.armband`` convention.
    electrode_shift : float
        Rotation of the armband in electrode spacings (positive towards higher
        channel numbers; 0 is the paper's placement); ``sim.user.armband`` convention.
    fatigue_per_min : float
        Fractional fall of the sEMG median frequency per minute (amplitude
        rises twice as fast); ``sim.user.emg_noise`` convention.
    """

    population_seed: int = Field(0, ge=0, le=MAX_SEED)
    subject_id: int = Field(1, ge=1, le=9999)
    generator: str = "noise"
    extra_noise_lsb: float = Field(0.0, ge=0.0, le=30.0)
    electrode_shift: float = Field(0.0, ge=-4.0, le=4.0)
    fatigue_per_min: float = Field(0.0, ge=0.0, le=0.5)

    @field_validator("generator")
    @classmethod
    def _registered_generator(cls, value: str) -> str:
        return check_registered(value, generator_names())


class ProtocolConfig(StrictModel):
    """What the subject does, and for how long.

    Attributes
    ----------
    name : {"paper_calibration", "grasp_lift_hold", "fragile_handling", "virtual_eggs", \
"slip_recovery", "force_matching", "timed_transfers"}
        The paper's three-squeeze FSR session, a Johansson-Westling
        grasp-lift-hold, handling a breakable object, or one of the feedback
        benchmarks (:mod:`scenarios.runners.feedback_tasks`): transferring a
        fragile block (Virtual Eggs Test), recovering an object whose load
        rises until it slips, holding a target force; or moving blocks over a
        partition for a minute (:mod:`scenarios.runners.transfers`).
    calibration_s : float or None
        Duration of the calibration session used to fit the estimator, s;
        ``None`` keeps the paper protocol's own length (about 25-36 s).
    episode_s : float or None
        Length of the closed-loop episode, s: the time limit of a trial the
        user paces (they lift when the grip looks secure and try again; a
        trial that runs out before a secure lift is ``not_lifted``), or the
        scripted user's whole episode. ``None``: 15 s for a user who paces the
        trial, 6 s for the scripted user.
    hold_s : float
        How long the object is held in the air, s (the scripted user: the end
        of the episode).
    identification_fraction : float
        Fraction of the calibration session used for identification; the rest
        validates (the paper uses 0.5).
    trials : int
        Consecutive trials of one user in one scenario (``virtual_eggs``:
        transfers of the block; ``slip_recovery``: slipping loads); the user
        plans each from the last (anticipatory scaling).
    target_fraction : float
        ``force_matching``: the hand force to hold, as a fraction of the hand
        force at the user's MVC.
    load_rate_n_s : float
        ``slip_recovery``: rate at which the load on the held object rises, N/s.
    perturbation, opening, opening_window_s : {"rising_load", "opening"}, float, float
        ``slip_recovery``: griploop's rising load, or Aboseria et al. 2018's involuntary
        opening: the fraction of the command lost, (0, 1], at a time drawn uniformly
        over the window, s (defaults' reasons: :mod:`scenarios.runners.slip_perturbations`).
    duration_s : float
        ``timed_transfers``: how long the user moves blocks, s (the Box and
        Blocks Test's 60).
    reach_s, transport_s : float or None
        ``timed_transfers``: how long the arm takes to reach back for the next
        block, and to carry one over the partition (up in half of it, down in
        the other half), s; ``None``: the user's ``lift_s`` (0.6 s), as before
        these fields existed (:mod:`scenarios.runners.transfers`).
    blocks : int or None
        ``timed_transfers``: move this many blocks, untimed (Raveh et al. 2018's
        16), instead of blocks in ``duration_s``; ``None``: the timed test.
    """

    name: Literal["paper_calibration", "grasp_lift_hold", "fragile_handling", "virtual_eggs",
                  "slip_recovery", "force_matching", "timed_transfers"] = "grasp_lift_hold"
    calibration_s: float | None = Field(None, ge=5.0, le=600.0)
    episode_s: float | None = Field(None, ge=0.5, le=120.0)
    hold_s: float = Field(2.0, ge=0.0, le=60.0)
    identification_fraction: float = Field(0.5, gt=0.05, lt=0.95)
    trials: int = Field(3, ge=1, le=100)
    target_fraction: float = Field(0.4, gt=0.0, le=1.0)
    load_rate_n_s: float = Field(1.0, gt=0.0, le=50.0)
    perturbation: Literal["rising_load", "opening"] = added_field("rising_load")
    opening: float = added_field(0.5, gt=0.0, le=1.0)
    opening_window_s: float = added_field(2.0, gt=0.0, le=10.0)
    duration_s: float = Field(60.0, ge=10.0, le=600.0)
    reach_s: float | None = added_field(None, ge=0.1, le=3.0)
    transport_s: float | None = added_field(None, ge=0.1, le=3.0)
    blocks: int | None = added_field(None, ge=1, le=60)

    @model_validator(mode="after")
    def _hold_fits(self) -> ProtocolConfig:
        if self.episode_s is not None and self.hold_s >= self.episode_s:
            raise ValueError(
                f"hold_s must be shorter than episode_s={self.episode_s:g} s "
                f"(found hold_s={self.hold_s:g} s)"
            )
        return self


class ObjectConfig(StrictModel):
    """The object to grasp: a library object and optional overrides.

    Fields left at ``None`` keep the library object's value.

    Attributes
    ----------
    name : str
        Object registered in :mod:`sim.hand.objects` (``ball``, ``can``,
        ``cup``, ``egg``, ``block``, ...).
    shape : {"sphere", "cylinder", "box"} or None
        Geometry override.
    mass_kg : float or None
        Mass, 0.005..2 kg.
    friction : float or None
        Sliding friction coefficient with the finger pads, 0.2..1.5.
    size_m : list of float or None
        Sphere ``[radius]``, cylinder ``[radius, half_height]`` or box
        ``[half_x, half_y, half_z]``, metres.
    stiffness_n_per_m : float or None
        Contact stiffness, N/m (the episode runner maps it to MuJoCo's
        ``solref``).
    break_force_n : float or None
        Grip force at which the object breaks (fragile objects), N.
    """

    name: str = "ball"
    shape: Literal["sphere", "cylinder", "box"] | None = None
    mass_kg: float | None = Field(None, ge=0.005, le=2.0)
    friction: float | None = Field(None, ge=0.2, le=1.5)
    size_m: list[Annotated[float, Field(gt=0.0, le=0.2)]] | None = Field(
        None, min_length=1, max_length=3
    )
    stiffness_n_per_m: float | None = Field(None, gt=0.0, le=1e7)
    break_force_n: float | None = Field(None, gt=0.0, le=500.0)

    @field_validator("name")
    @classmethod
    def _registered_object(cls, value: str) -> str:
        return check_registered(value, object_names())

    @model_validator(mode="after")
    def _size_matches_shape(self) -> ObjectConfig:
        if self.shape is not None and self.size_m is not None:
            expected = SIZE_LENGTHS[self.shape]
            if len(self.size_m) != expected:
                raise ValueError(
                    f"size_m of a {self.shape} needs {expected} value(s) "
                    f"(found {len(self.size_m)})"
                )
        return self


class EstimatorConfig(StrictModel):
    """The grip-force estimator and how it is evaluated.

    Attributes
    ----------
    name : str
        An estimator registered in :mod:`estimation.registry`, or ``"oracle"``
        (the user's true intent: a perfect estimator), see
        :func:`~scenarios.schema.names.estimator_choices`.
    mode : {"one_step", "free_run"}
        ``one_step`` feeds measured force up to k-1 (the paper's evaluation);
        ``free_run`` uses sEMG only (what a prosthesis can do).
    order : int or None
        State-space order (also NARX delays and hidden units); ``None`` uses
        the paper's n = 4, which its AIC over n = 1..12 selected.
    options : dict
        The estimator's own hyperparameters (its ``get_params``, e.g. an MLP's
        ``alpha``), except the order, seed and feature period an evaluation
        sets; each value has the type of its default.
    window_ms : float
        Feature window, ms: the paper's 400 (50..1000). The sEMG path's
        latency grows with it; research uses 150-250 ms as well.
    step_ms : float
        Window increment, ms: the paper's 125 (10..500, at most the window);
        the estimator updates at this period.
    """

    name: str = "ss_kf"
    mode: Literal["one_step", "free_run"] = "free_run"
    order: int | None = Field(None, ge=1, le=12)
    options: dict[str, Any] = added_field(default_factory=dict)
    window_ms: float = Field(400.0, ge=WINDOW_RANGE_MS[0], le=WINDOW_RANGE_MS[1])
    step_ms: float = Field(125.0, ge=STEP_RANGE_MS[0], le=STEP_RANGE_MS[1])

    @model_validator(mode="after")
    def _step_fits_window(self) -> EstimatorConfig:
        if self.step_ms > self.window_ms:
            raise ValueError(f"step_ms must not exceed window_ms={self.window_ms:g} ms "
                             f"(found step_ms={self.step_ms:g} ms)")
        return self

    @field_validator("name")
    @classmethod
    def _registered_estimator(cls, value: str) -> str:
        return check_registered(value, estimator_choices())

    @field_validator("options")
    @classmethod
    def _declared_options(cls, value: dict[str, Any], info: Any) -> dict[str, Any]:
        name = info.data.get("name")
        if name is None or not value:  # the name itself failed (reported), or nothing set
            return value
        return check_declared_options(f"estimator {name}", value, estimator_own_options(name))


class SlipReflexConfig(StrictModel):
    """Slip reflex: raise the grip force when the object slips.

    Attributes
    ----------
    enabled : bool
        Whether the reflex is active.
    latency_s : float
        Delay from slip onset to the force increase, s (biological 0.02-0.3).
    gain : float
        Force increase per slip event as a fraction of the current reference.
    """

    enabled: bool = False
    latency_s: float = Field(0.05, ge=0.0, le=0.5)
    gain: float = Field(0.3, ge=0.0, le=5.0)


class ControllerConfig(StrictModel):
    """The grip-force controller, designed from a specification.

    Attributes
    ----------
    kind : str
        Controller kind registered in :mod:`controllers.registry` (``pid``,
        ``lead_lag``, ``mpc``, ...).
    phase_margin_deg : float
        Required phase margin, degrees.
    crossover_rad_s : float or None
        Required gain-crossover frequency, rad/s (exclusive with bandwidth).
    bandwidth_rad_s : float or None
        Required closed-loop bandwidth, rad/s (exclusive with crossover).
    horizon : int or None
        MPC prediction horizon in control steps (kinds that take a horizon
        only, e.g. ``mpc``; default: the kind's registered default, 20).
    solver : str or None
        QP solver of the kinds that solve one (``mpc``): ``daqp`` (default, with the
        checked unconstrained fast path), ``osqp`` or ``proxqp``.
    safety_factor : float
        Grip force over the sensed slip threshold that a kind with a slip bound
        keeps (the MPC's ``safety x load / (2 mu_hat)``). The user's own aim is
        theirs (a novice 1.5x; a practised user what practice taught:
        :mod:`sim.user.belief`), not this.
    control_hz : float
        Control-loop rate, Hz: 100 to 500, so that the control period is a
        whole number of the hand's 2 ms physics steps.
    slip_reflex : SlipReflexConfig
        Slip reflex settings.
    scheduled : bool
        Gain-scheduled over grip force (default) or one fixed design at the
        design force (see :mod:`controllers.schedule`).
    options : dict
        The kind's own design options as registered
        (:func:`controllers.registry.register_controller` ``options``, e.g.
        ``lag_ratio`` of ``lead_lag``), except those with a field here
        (``horizon``, ``solver``); each value has the type of the kind's default.
    """

    kind: str = "pid"
    phase_margin_deg: float = Field(60.0, ge=10.0, le=90.0)
    crossover_rad_s: float | None = Field(None, gt=0.0, le=5000.0)
    bandwidth_rad_s: float | None = Field(None, gt=0.0, le=5000.0)
    horizon: int | None = Field(None, ge=2, le=500)
    solver: str | None = None
    safety_factor: float = Field(1.5, ge=1.0, le=5.0)
    control_hz: float = Field(100.0, ge=100.0, le=500.0)
    slip_reflex: SlipReflexConfig = Field(default_factory=SlipReflexConfig)
    scheduled: bool = True
    options: dict[str, Any] = added_field(default_factory=dict)

    @field_validator("kind")
    @classmethod
    def _registered_controller(cls, value: str) -> str:
        return check_registered(value, controller_names())

    @field_validator("options")
    @classmethod
    def _declared_options(cls, value: dict[str, Any], info: Any) -> dict[str, Any]:
        kind = info.data.get("kind")
        if kind is None:  # the kind itself failed; its error is reported
            return value
        return check_declared_options(f"controller {kind}", value,
                                      controller_own_options(kind))

    @model_validator(mode="after")
    def _consistent(self) -> ControllerConfig:
        if self.crossover_rad_s is not None and self.bandwidth_rad_s is not None:
            raise ValueError(
                "give crossover_rad_s or bandwidth_rad_s, not both "
                f"(found {self.crossover_rad_s:g} and {self.bandwidth_rad_s:g})"
            )
        from controllers.registry import controller_info

        with_horizon = [k for k in controller_names() if "horizon" in controller_info(k)["options"]]
        if self.kind not in with_horizon and self.horizon is not None:
            which = "kind" if len(with_horizon) == 1 else "kinds"
            raise ValueError(f"horizon applies to controller {which} {', '.join(with_horizon)} "
                             f"only (found kind {self.kind})")
        if self.kind in with_horizon and self.horizon is None:
            self.horizon = int(controller_info(self.kind)["defaults"].get("horizon", 20))
        with_solver = [k for k in controller_names() if "solver" in controller_info(k)["options"]]
        if self.kind not in with_solver and self.solver is not None:
            raise ValueError(f"solver applies to controller kind(s) {', '.join(with_solver)} "
                             f"only (found kind {self.kind})")
        if self.solver is not None:
            from controllers.mpc import QP_SOLVERS  # imported only when a solver is named

            check_registered(self.solver, QP_SOLVERS)
        return self


def _operator_params_model() -> type[BaseModel]:
    """A pydantic model of :class:`sim.user.operator.OperatorParams` with its ranges."""
    from pydantic import create_model

    from sim.user.operator import OperatorParams

    fields: dict[str, Any] = {}
    for name, spec in OperatorParams.ranges().items():
        lo, hi = spec["range"]
        bound = {"gt": lo} if spec["open_low"] else {"ge": lo}
        kind = int if spec["integer"] else float
        make = added_field if spec["added"] else Field
        fields[name] = (kind, make(spec["default"], le=hi, **bound))
    return create_model("OperatorParamsConfig", __base__=StrictModel,
                        __doc__="The reacting user's parameters (sim.user.operator.OperatorParams)",
                        **fields)


OperatorParamsConfig = _operator_params_model()


class UserConfig(StrictModel):
    """The person in the loop: who drives the intent, and what they feel.

    Attributes
    ----------
    kind : str
        User kind registered in :mod:`sim.user.operators`: ``reacting`` (sees
        the hand and corrects; the default of closed-loop scenarios) or
        ``scripted`` (follows the intent profile whatever happens). The
        calibration session is always scripted: it follows cues.
    feedback : str
        Feedback mode registered in :mod:`sim.user.operators`: ``none``
        (vision only), ``force_vibration`` or ``slip_vibration``; only for a
        user kind that takes feedback.
    params : OperatorParamsConfig
        The reacting user's parameters, each within its physical range
        (:class:`sim.user.operator.OperatorParams` lists them with sources).
    practice : int
        Practice lifts of the object's class with the same estimator,
        controller and feedback before the measured trials (0..50; default 5;
        0 is the novice). A user kind that does not learn ignores it.
    vision : bool
        The user sees the hand and the object in the measured trials (``False``: not;
        :mod:`sim.user.reacting`, "without vision"). Practice is with vision.
    """

    kind: str = "reacting"
    feedback: str = "none"
    practice: int = Field(5, ge=PRACTICE_RANGE[0], le=PRACTICE_RANGE[1])
    params: OperatorParamsConfig = Field(default_factory=OperatorParamsConfig)  # type: ignore[valid-type]
    vision: bool = added_field(True)

    @field_validator("kind")
    @classmethod
    def _registered_kind(cls, value: str) -> str:
        return check_registered(value, user_kinds())

    @field_validator("feedback")
    @classmethod
    def _registered_feedback(cls, value: str) -> str:
        return check_registered(value, feedback_modes())

    @model_validator(mode="after")
    def _feedback_fits_kind(self) -> UserConfig:
        from sim.user.operators import takes_feedback

        if self.feedback != "none" and not takes_feedback(self.kind):
            kinds = ", ".join(k for k in user_kinds() if takes_feedback(k))
            raise ValueError(f"feedback {self.feedback} needs a user kind that takes feedback "
                             f"({kinds}); user {self.kind} takes feedback none only")
        return self

    def operator_params(self) -> Any:
        """The :class:`sim.user.operator.OperatorParams` of :attr:`params`."""
        from sim.user.operator import OperatorParams

        return OperatorParams(**self.params.model_dump())


class HandConfig(StrictModel):
    """The prosthetic hand's mechanism.

    Attributes
    ----------
    drive : str
        The transmission registered in :mod:`sim.hand.drive`: ``backdrivable`` (default)
        or ``self_locking`` (a worm stage: the digits move only under motor torque and
        hold without it).
    """

    drive: str = "backdrivable"

    @field_validator("drive")
    @classmethod
    def _registered_drive(cls, value: str) -> str:
        return check_registered(value, drive_names())


class Scenario(StrictModel):
    """One experiment: subject, protocol, object, estimator, controller, user, seed.

    Attributes
    ----------
    kind : str
        A scenario kind registered in :mod:`scenarios.runners.dispatch`:
        ``reproduction`` evaluates an estimator on the paper's protocol as the
        paper does; ``calibration`` fits it on a calibration session;
        ``episode`` also runs a closed-loop grasp with the controller. Each
        kind's registration lists the protocols it runs.
    seed : int or None
        Seed of every random draw of the scenario; ``None`` in a sweep file
        means "derive it from the sweep seed and the content".
    hand : HandConfig
        The hand's mechanism (``hand.drive``).
    paradigm : str
        How the hand's reference follows the estimate, registered in
        :mod:`controllers.paradigms` (``force``, default; ``force_hold``).
    auto_grip : bool
        The hand's own slip response (:data:`controllers.reflex.AUTO_GRIP`).
    decoder : str or None
        The open/close decoder (:mod:`estimation.decoding`: ``two_site``, ``pattern``);
        ``None``: none, or the default one when the paradigm needs one (``velocity``).
    """

    kind: str = "episode"
    subject: SubjectConfig = Field(default_factory=SubjectConfig)
    protocol: ProtocolConfig = Field(default_factory=ProtocolConfig)
    object: ObjectConfig = Field(default_factory=ObjectConfig)
    estimator: EstimatorConfig = Field(default_factory=EstimatorConfig)
    controller: ControllerConfig = Field(default_factory=ControllerConfig)
    user: UserConfig = Field(default_factory=UserConfig)
    seed: int | None = Field(None, ge=0, le=MAX_SEED)
    hand: HandConfig = added_field(default_factory=HandConfig)
    paradigm: str = added_field("force")
    auto_grip: bool = added_field(False)
    decoder: str | None = added_field(None)

    @field_validator("kind")
    @classmethod
    def _registered_kind(cls, value: str) -> str:
        return check_registered(value, scenario_kinds())

    @field_validator("paradigm")
    @classmethod
    def _registered_paradigm(cls, value: str) -> str:
        return check_registered(value, paradigm_names())

    @field_validator("decoder")
    @classmethod
    def _registered_decoder(cls, value: str | None) -> str | None:
        return None if value is None else check_registered(value, decoder_names())

    @model_validator(mode="after")
    def _protocol_fits_kind(self) -> Scenario:
        protocols = kind_protocols(self.kind)
        if protocols and self.protocol.name not in protocols:
            raise ValueError(
                f"kind {self.kind} needs protocol.name {' or '.join(protocols)} "
                f"(found {self.protocol.name})"
            )
        return self

    def canonical_dict(self) -> dict[str, Any]:
        """Every field as JSON types, without the fields added later left at their defaults.

        The fields made with :func:`~scenarios.schema.canonical.added_field` (the kinds'
        ``options`` among them) are
        left out while at their defaults, so a scenario that sets none of them hashes and
        seeds as it did before they existed.
        """
        return omit_added_defaults(self, self.model_dump(mode="json"))

    def canonical_json(self) -> str:
        """The scenario as canonical JSON (:meth:`canonical_dict`), sorted keys, no spaces."""
        return json.dumps(self.canonical_dict(), sort_keys=True, separators=(",", ":"))

