"""``GraspEnv``: grasp, lift and hold an object with the MuJoCo prosthetic hand.

Episode: the object rests on the table with the open hand around it. The agent
commands the motor (normalized armature voltage, -1..1) every control period
to track a grip-force reference. The wrist follows a :class:`WristSchedule`
(lift once the grip is established, hold, optionally shake and place) or, with
``wrist="commanded"``, its user's own moves (:meth:`GraspEnv.move_wrist`,
:mod:`sim.hand.wrist`): the person in the loop lifts when they choose. The hand
(:class:`~sim.hand.env_spec.HandSpec`: drive, motor, pads, physics timestep) and
the task (:class:`~sim.hand.env_spec.GraspTask`: duration, reward, ending, reset)
are given as specs.

Observation (float32, ``GraspEnv.OBS_NAMES``)::

    0 reference_n            grip-force reference, N
    1 grip_force_n           thumb-side contact normal force sum, N (sim.hand.contact)
    2 finger_position_rad    index joint encoder, rad (0 = straight down, + closes)
    3 finger_velocity_rad_s  index joint velocity, rad/s
    4 motor_current_a        armature current, A (sim.hand.model.MotorSpec)

Physical readings of the last physics substep are in ``info`` and in
``env.last_info``; reward terms in ``info["reward_terms"]``. A load can be hung
on the object during an episode (:meth:`GraspEnv.set_object_load`).
"""

from __future__ import annotations

import math
from typing import Any

import gymnasium as gym
import mujoco
import numpy as np
from gymnasium import spaces

from sim.hand.contact import ContactReading, OutcomeTracker, read_contacts
from sim.hand.drive import DigitLock, make_drive, motor_for
from sim.hand.env_spec import GraspTask, HandSpec, RewardWeights
from sim.hand.errors import GraspFailedError, HandSpecError
from sim.hand.model import HandIds, build_model
from sim.hand.objects import ObjectSpec, as_object_spec
from sim.hand.preshape import Preshape
from sim.hand.wrist import CommandedWrist, WristSchedule, min_jerk
from sim.references import Reference, StreamReference, as_reference

__all__ = ["G_M_S2", "GraspEnv", "GraspTask", "HandSpec", "RewardWeights", "WristSchedule",
           "CommandedWrist"]

G_M_S2 = 9.81


class GraspEnv(gym.Env):
    """Grasp-and-lift of one object by the single-drive prosthetic hand.

    Parameters
    ----------
    object : ObjectSpec, str or dict
        The object (library name, spec, or ``{"name": ..., **overrides}``).
    reference : float, array, callable, Recording or Reference
        Grip-force reference (see :mod:`sim.references`); arrays are sampled at
        ``control_dt_s``.
    control_dt_s : float
        Control period in seconds (default 10 ms, 100 Hz); a whole multiple of
        ``hand.physics_dt_s``.
    wrist : WristSchedule or {"scheduled", "commanded"}
        A :class:`WristSchedule` the wrist follows (``"scheduled"``: the default
        ``WristSchedule()``); ``"commanded"`` stays at the approach pose until
        :meth:`move_wrist` moves it (the user's own arm).
    hand : HandSpec, optional
        The simulated hand: drive, motor, pads and physics timestep (default
        ``HandSpec()``: the backdrivable hand at 2 ms).
    task : GraspTask, optional
        The episode: duration, reward weights, whether a drop ends it, slip and
        drop thresholds, placement jitter (default ``GraspTask()``: 4 s).
    render_mode : {None, "rgb_array"}
        ``"rgb_array"`` renders headless with ``mujoco.Renderer``.
    render_size : tuple of int
        ``(height, width)`` of rendered frames in pixels.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 100}
    OBS_NAMES = ("reference_n", "grip_force_n", "finger_position_rad", "finger_velocity_rad_s",
                 "motor_current_a")

    def __init__(self, object: ObjectSpec | str | dict = "ball", reference: Any = 10.0, *,
                 control_dt_s: float = 0.01, wrist: WristSchedule | str = "scheduled",
                 hand: HandSpec | None = None, task: GraspTask | None = None,
                 render_mode: str | None = None,
                 render_size: tuple[int, int] = (480, 640)) -> None:
        hand = HandSpec() if hand is None else hand
        task = GraspTask() if task is None else task
        physics_dt_s, episode_s = hand.physics_dt_s, task.episode_s
        position_jitter_m = task.position_jitter_m
        if not 0.001 <= physics_dt_s <= 0.002 + 1e-12:
            raise HandSpecError(f"physics_dt_s: expected 0.001..0.002 s, found {physics_dt_s!r}")
        n_sub = round(control_dt_s / physics_dt_s)
        if n_sub < 1 or abs(n_sub * physics_dt_s - control_dt_s) > 1e-9:
            raise HandSpecError(
                f"control_dt_s: expected a whole multiple of physics_dt_s={physics_dt_s} s, "
                f"found {control_dt_s!r}"
            )
        if not episode_s > 0:
            raise HandSpecError(f"episode_s: expected a positive duration, found {episode_s!r}")
        if isinstance(wrist, WristSchedule):
            schedule, wrist = wrist, "scheduled"
        elif wrist in ("scheduled", "commanded"):
            schedule = WristSchedule()
        else:
            raise HandSpecError(f"wrist: expected a WristSchedule, 'scheduled' or 'commanded', "
                                f"found {wrist!r}")
        if render_mode not in (None, "rgb_array"):
            raise HandSpecError(f"render_mode: expected None or 'rgb_array', found {render_mode!r}")
        if not 0 <= position_jitter_m <= 0.01:
            raise HandSpecError(
                f"position_jitter_m: expected 0..0.01 m, found {position_jitter_m!r}"
            )
        if task.preshape_aperture_m is not None and make_drive(hand.drive).self_locking:
            raise HandSpecError("preshape_aperture_m: a self-locking drive holds its digits "
                                "with stops of its own; expected the backdrivable drive")
        self.hand, self.task = hand, task
        self.control_dt_s = float(control_dt_s)
        self.physics_dt_s = float(physics_dt_s)
        self.n_substeps = int(n_sub)
        self.episode_s = float(episode_s)
        self.max_steps = int(round(episode_s / control_dt_s))
        self.schedule = schedule
        self.commanded: CommandedWrist | None = CommandedWrist() if wrist == "commanded" else None
        self.terminate_on_drop = bool(task.terminate_on_drop)
        self.drive = make_drive(hand.drive)
        self.motor = motor_for(self.drive, hand.motor)
        self.pads = hand.pads
        self.weights = task.reward_weights
        self.position_jitter_m = float(position_jitter_m)
        self.render_mode = render_mode
        self.render_size = render_size
        self.metadata = {**self.metadata, "render_fps": int(round(1.0 / control_dt_s))}
        self.reference: Reference = as_reference(reference, self.control_dt_s)
        self.tracker = OutcomeTracker(task.slip_threshold_m_s, task.drop_distance_m)
        self._renderer: mujoco.Renderer | None = None
        self._load_object(as_object_spec(object))

        i_max = 2.0 * self.motor.stall_current_a
        high = np.array([500.0, 1000.0, 1.6, 100.0, i_max], dtype=np.float32)
        low = np.array([0.0, 0.0, -0.6, -100.0, -i_max], dtype=np.float32)
        self.observation_space = spaces.Box(low, high, dtype=np.float32)
        self.action_space = spaces.Box(-1.0, 1.0, shape=(1,), dtype=np.float32)
        self._obs_lo, self._obs_hi = low.tolist(), high.tolist()
        self.last_info: dict[str, Any] = {}

    # ------------------------------------------------------------------ setup
    def _load_object(self, obj: ObjectSpec) -> None:
        self.object_spec = obj
        self.model = build_model(obj, self.motor, self.physics_dt_s, self.pads)
        self.data = mujoco.MjData(self.model)
        self.ids = HandIds.from_model(self.model)
        self.tracker.break_force_n = obj.break_force_n
        self._obj_rgba = self.model.geom_rgba[self.ids.object_geom].copy()
        self._contacts = ContactReading()
        # Persistent views on mjData and plain-int indices for the step loop.
        self._ctrl = self.data.ctrl
        self._sens = self.data.sensordata
        self._i_motor = int(self.ids.motor)
        self._i_wrist_z = int(self.ids.wrist_act[2])
        self._k_in_palm = int(self.ids.sens_object_in_palm)
        self._obj_body = int(self.ids.object_body)
        self._load_n = 0.0
        ids = self.ids
        self._k_obs = (int(ids.sens_finger_pos), int(ids.sens_finger_vel),
                       int(ids.sens_motor_force), int(ids.sens_object_pos) + 2)
        self._f32 = np.dtype(np.float32)
        # MotorSpec.current_a's divisor, evaluated once (same expression, same float)
        self._force_per_current = (self.motor.efficiency * self.motor.gear_ratio
                                   * self.motor.torque_constant_nm_a)
        self._windows: tuple[tuple[float, float], ...] = ()
        self._windows_key: tuple[WristSchedule, float] | None = None
        self._preshape = Preshape(self.model)  # the digits' start pose (the intact hand)
        # a self-locking drive holds each digit with stops that follow it
        self._lock = (DigitLock(self.model, self.data, self.drive, self.motor,
                                self.control_dt_s) if self.drive.self_locking else None)
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None

    def set_object_load(self, force_n: float) -> None:
        """Pull the object down with ``force_n`` (N) from the next step on (a load in the hand).

        A vertical external force on the object's centre, as a weight added to
        it or a pull on it; cleared by :meth:`reset`. Reported as
        ``info["object_load_n"]``.

        Raises
        ------
        HandSpecError
            A negative or non-finite force.
        """
        f = float(force_n)
        if not (math.isfinite(f) and f >= 0):
            raise HandSpecError(f"object load: expected a force >= 0 N, found {force_n!r}")
        self._load_n = f
        self.data.xfrc_applied[self._obj_body, 2] = -f

    def move_wrist(self, height_m: float, duration_s: float, path: str = "min_jerk") -> None:
        """Start a wrist move to ``height_m`` (m above the approach pose) over ``duration_s``.

        The move starts now (the current episode time) from the wrist's
        set-point along a minimum-jerk path, or with ``path="follow"`` as one
        segment of a measured arm's path (:class:`sim.hand.wrist.CommandedWrist`).

        Raises
        ------
        HandSpecError
            The environment was made with ``wrist="scheduled"``, or a height,
            duration or path out of range.
        """
        if self.commanded is None:
            raise HandSpecError("move_wrist: this environment's wrist follows its schedule; "
                                "make it with wrist='commanded' to move it")
        self.commanded.move(self.data.time, height_m, duration_s, path)

    def set_reference(self, force_n: float) -> None:
        """Push the next reference value (N), e.g. an estimator's output.

        Switches to a :class:`sim.references.StreamReference` if needed.
        """
        if not isinstance(self.reference, StreamReference):
            self.reference = StreamReference(force_n)
        self.reference.push(force_n)

    # ------------------------------------------------------------------ API
    def reset(self, *, seed: int | None = None,
              options: dict[str, Any] | None = None) -> tuple[np.ndarray, dict[str, Any]]:
        """Start an episode.

        Parameters
        ----------
        seed : int, optional
            Seeds ``self.np_random`` (object placement jitter).
        options : dict, optional
            ``"reference"``: a new reference (any :func:`~sim.references.as_reference` input);
            ``"object"``: a new object (rebuilds the model).
        """
        super().reset(seed=seed)
        options = options or {}
        if "object" in options:
            obj = as_object_spec(options["object"])
            if obj != self.object_spec:
                self._load_object(obj)
        if "reference" in options:
            self.reference = as_reference(options["reference"], self.control_dt_s)
        self.reference.reset()
        m, d, ids = self.model, self.data, self.ids
        mujoco.mj_resetData(m, d)  # clears xfrc_applied: no load
        self._load_n = 0.0
        m.geom_rgba[ids.object_geom] = self._obj_rgba
        if self.position_jitter_m > 0:
            jitter = self.np_random.uniform(-self.position_jitter_m, self.position_jitter_m, 2)
            d.qpos[ids.object_qpos:ids.object_qpos + 2] += jitter
        if self.task.preshape_aperture_m is not None:  # the digits pre-shaped to the object
            self._preshape.apply(d, self.task.preshape_aperture_m)
        elif self._preshape.angle_rad is not None:
            self._preshape.clear()
        mujoco.mj_forward(m, d)
        self._step_count = 0
        self._lift_start_s: float | None = None
        if self.commanded is not None:
            self.commanded.reset()
        if self._lock is not None:
            self._lock.reset()
        self._clipped = 0
        self._warn_view = d.warning.number  # a view on mjData, updated in place
        self._warnings = self._warn_view.tolist()
        s = d.sensordata
        k = ids.sens_object_in_palm
        self.tracker.reset((s.item(k), s.item(k + 1), s.item(k + 2)))
        read_contacts(m, d, ids, self._contacts)
        ref = self.reference.value(0.0)
        return self._observe_info(ref, {"tracking": 0.0, "slip": 0.0, "drop": 0.0, "crush": 0.0},
                                  None)

    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """Apply the motor command for one control period.

        Parameters
        ----------
        action : array, shape (1,)
            Normalized motor command; values outside -1..1 (or NaN, taken as 0)
            are clipped and counted in ``info["action_clipped_count"]``.
        """
        m, d = self.model, self.data
        try:
            u = float(action[0])
        except (TypeError, IndexError):
            u = float(np.asarray(action).reshape(-1)[0])
        if not -1.0 <= u <= 1.0:
            self._clipped += 1
            u = 0.0 if u != u else (1.0 if u > 1.0 else -1.0)
        ctrl = self._ctrl
        ctrl[self._i_motor] = u
        if self._lock is not None:
            self._lock.step(u)
        t = d.time
        commanded = self.commanded
        if commanded is not None:
            self._step_commanded(commanded, t)
        else:
            self._step_scheduled(t)
        self._step_count += 1

        # MuJoCo checks qpos/qvel/qacc for NaN, inf and huge values itself
        # (mjWARN_BADQPOS/BADQVEL/BADQACC, then resets the state): any new
        # warning ends the episode.
        failure = None
        warnings_now = self._warn_view.tolist()
        if warnings_now != self._warnings:
            failure = self._warning_name(warnings_now)
            self._warnings = warnings_now

        c = read_contacts(m, d, self.ids, self._contacts)
        s = self._sens
        k = self._k_in_palm
        tr = self.tracker
        was_dropped, was_crushed = tr.dropped, tr.crushed
        tr.update(c, (s.item(k), s.item(k + 1), s.item(k + 2)))
        if tr.crushed and not was_crushed:
            m.geom_rgba[self.ids.object_geom] = (0.3, 0.25, 0.2, 1.0)
        ref = self.reference.value(d.time)
        w = self.weights
        grip = c.grip_force_n
        tracking = -w.tracking * abs(ref - grip) / w.force_scale_n
        slip = -w.slip * c.slip_speed_m_s / 0.01 if c.thumb_contact and c.finger_contact else 0.0
        drop = -w.drop if tr.dropped and not was_dropped else 0.0
        crush = -w.crush if tr.crushed and not was_crushed else 0.0
        terms = {"tracking": tracking, "slip": slip, "drop": drop, "crush": crush}
        reward = tracking + slip + drop + crush
        terminated = (tr.dropped and self.terminate_on_drop) or tr.crushed
        truncated = self._step_count >= self.max_steps or failure is not None
        obs, info = self._observe_info(ref, terms, failure)
        return obs, float(reward), bool(terminated), bool(truncated), info

    def _step_scheduled(self, t: float) -> None:
        """Physics of one control period with the wrist on its schedule."""
        m, d, ctrl, schedule = self.model, self.data, self._ctrl, self.schedule
        if self._lift_start_s is None and t >= schedule.lift_after_s - 1e-9:
            c = self._contacts
            if (c.thumb_contact and c.finger_contact
                    and c.grip_force_n >= schedule.lift_min_grip_n):
                self._lift_start_s = t
        lift_start = self._lift_start_s
        if lift_start is not None and self._moves(t, t + self.control_dt_s, lift_start):
            # While the wrist moves its path is sampled at every physics
            # substep: a set-point held over the control period is a staircase
            # that the stiff wrist servo follows with acceleration spikes of
            # about 2 g, which shook light objects out of the grasp
            # (docs/HAND.md, "The lift").
            self._substeps(lambda s: schedule.height_m(s, lift_start), t)
        else:
            ctrl[self._i_wrist_z] = schedule.height_m(t + self.control_dt_s, lift_start)
            mujoco.mj_step(m, d, self.n_substeps)

    def _step_commanded(self, wrist: CommandedWrist, t: float) -> None:
        """Physics of one control period with the wrist where its user moves it."""
        if wrist.moves_during(t, t + self.control_dt_s):
            self._substeps(wrist.height_m, t)  # sampled per substep, as a scheduled lift
        else:
            self._ctrl[self._i_wrist_z] = wrist.height_m(t + self.control_dt_s)
            mujoco.mj_step(self.model, self.data, self.n_substeps)
        self._lift_start_s = wrist.first_rise_s

    def _substeps(self, height_m: Any, t: float) -> None:
        """The control period's physics substeps with the wrist at ``height_m(time)``."""
        m, d, ctrl, dt, i_wrist = self.model, self.data, self._ctrl, self.physics_dt_s, \
            self._i_wrist_z
        step = mujoco.mj_step
        for i in range(1, self.n_substeps + 1):
            ctrl[i_wrist] = height_m(t + i * dt)
            step(m, d)

    def render(self) -> np.ndarray | None:
        """An RGB frame ``(height, width, 3)`` uint8 from the ``front`` camera."""
        if self.render_mode != "rgb_array":
            return None
        if self._renderer is None:
            h, w = self.render_size
            self._renderer = mujoco.Renderer(self.model, height=h, width=w)
        self._renderer.update_scene(self.data, camera="front")
        return self._renderer.render()

    def close(self) -> None:
        """Release the renderer."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
        super().close()

    # --------------------------------------------------------------- helpers
    def _observe_info(self, ref: float, terms: dict[str, float],
                      failure: str | None) -> tuple[np.ndarray, dict[str, Any]]:
        """Observation (clamped into the declared Box) and ``info`` of the current state.

        Each sensor value is read once and shared by both; plain floats and one
        dict literal are cheaper here than numpy calls.
        """
        c, tr = self._contacts, self.tracker
        s = self._sens
        grip = c.grip_force_n
        load = c.load_force_n
        k_pos, k_vel, k_force, k_height = self._k_obs
        finger_pos = s.item(k_pos)
        finger_vel = s.item(k_vel)
        current = s.item(k_force) / self._force_per_current
        lo, hi = self._obs_lo, self._obs_hi
        obs = np.array([lo[0] if ref < lo[0] else hi[0] if ref > hi[0] else ref,
                        lo[1] if grip < lo[1] else hi[1] if grip > hi[1] else grip,
                        lo[2] if finger_pos < lo[2] else hi[2] if finger_pos > hi[2]
                        else finger_pos,
                        lo[3] if finger_vel < lo[3] else hi[3] if finger_vel > hi[3]
                        else finger_vel,
                        lo[4] if current < lo[4] else hi[4] if current > hi[4] else current],
                       self._f32)
        info = {
            "time_s": self.data.time,
            "reference_n": ref,
            "grip_force_n": grip,
            "finger_force_n": c.finger_force_n,
            "load_force_n": load,
            "lift_force_n": c.lift_force_n,
            "grip_load_ratio": grip / load if load > 1e-6 else math.inf,
            "slip_speed_m_s": c.slip_speed_m_s,
            "thumb_contact": c.thumb_contact,
            "finger_contact": c.finger_contact,
            "slip_distance_m": tr.slip_distance_m,
            "slip_events": tr.slip_events,
            "dropped": tr.dropped,
            "crushed": tr.crushed,
            "object_height_m": s.item(k_height),
            "object_in_palm_z_m": s.item(self._k_in_palm + 2),
            "object_load_n": self._load_n,
            "object_displacement_m": tr.displacement_m,
            "object_out_of_hand": c.n_contacts == 0 and tr.displacement_m > tr.drop_distance_m,
            "finger_position_rad": finger_pos,
            "finger_velocity_rad_s": finger_vel,
            "motor_current_a": current,
            "motor_command": self._ctrl.item(self._i_motor),
            "lifted": self._lift_start_s is not None,
            "wrist_height_m": self._ctrl.item(self._i_wrist_z),
            "action_clipped_count": self._clipped,
            "reward_terms": terms,
        }
        if failure is not None:
            info["failure"] = failure
        self.last_info = info
        return obs, info

    def _moves(self, t0_s: float, t1_s: float, lift_start_s: float) -> bool:
        """:meth:`WristSchedule.moves_during` with the motion windows cached per lift."""
        key = self._windows_key
        if key is None or key[1] != lift_start_s or key[0] is not self.schedule:
            self._windows = self.schedule.motion_windows(lift_start_s)
            self._windows_key = (self.schedule, lift_start_s)
        for a, b in self._windows:
            if t0_s < b and a < t1_s:
                return True
        return False

    def _warning_name(self, numbers: list[int]) -> str:
        pairs = zip(numbers, self._warnings, strict=True)
        new = [mujoco.mjtWarning(i).name for i, (a, b) in enumerate(pairs) if a != b]
        return ",".join(new) if new else "mujoco_warning"

    # ------------------------------------------------------------- analysis
    def steady_grasp(self, grip_force_n: float, *, lifted: bool = False,
                     settle_s: float = 0.5, tol: float = 0.01, max_iter: int = 10,
                     close_command: float = 0.3) -> float:
        """Bring the current episode to a steady grasp at ``grip_force_n`` (N).

        Closes with ``close_command`` until both sides touch the object, then
        (with ``lifted=True``) raises the wrist by the schedule's lift height,
        holding at least twice the slip threshold ``m g / (2 mu)`` while it moves,
        and finally calls :meth:`hold_grip`. Physics advances outside the
        episode clock's schedule: afterwards the wrist stays where it is.

        Returns
        -------
        float
            The motor command holding the grasp.

        Raises
        ------
        RuntimeError
            If no grasp forms or the target cannot be reached.
        """
        if not 0 < grip_force_n < 0.9 * self.motor.max_grip_force_n:
            raise HandSpecError(
                f"grip_force_n: expected 0..{0.9 * self.motor.max_grip_force_n:.0f} N, "
                f"found {grip_force_n!r}"
            )
        m, d, ids = self.model, self.data, self.ids
        u = grip_force_n / self.motor.max_grip_force_n
        d.ctrl[ids.motor] = close_command
        c = self._contacts
        for _ in range(int(round(2.0 / self.physics_dt_s))):
            mujoco.mj_step(m, d)
            read_contacts(m, d, ids, c)
            if c.thumb_contact and c.finger_contact:
                break
        else:
            raise GraspFailedError("steady_grasp: the digits did not close on the object in 2 s")
        obj = self.object_spec
        safe_u = 2.0 * obj.mass_kg * G_M_S2 / (2.0 * obj.friction) / self.motor.max_grip_force_n
        d.ctrl[ids.motor] = max(u, safe_u) if lifted else u
        mujoco.mj_step(m, d, int(round(0.2 / self.physics_dt_s)))
        if lifted:
            steps = int(round(self.schedule.lift_duration_s / self.physics_dt_s))
            for i in range(steps + 1):
                d.ctrl[ids.wrist_act[2]] = self.schedule.lift_height_m * min_jerk(i / steps)
                mujoco.mj_step(m, d)
            self._lift_start_s = -math.inf
        # Lifted: start from the (safe) current command and come down to the target.
        return self.hold_grip(grip_force_n, None if lifted else u, settle_s=settle_s, tol=tol,
                              max_iter=max_iter)

    def hold_grip(self, grip_force_n: float, command: float | None = None, *,
                  settle_s: float = 0.5, tol: float = 0.01, max_iter: int = 10) -> float:
        """Adjust a held command until the settled grip force is ``grip_force_n`` (N).

        The stalled drive is close to proportional (grip ~ command), so each
        iteration scales the command by target / measured after ``settle_s``.

        Returns
        -------
        float
            The command; the grip is within ``tol`` (relative) of the target.
        """
        m, d, ids = self.model, self.data, self.ids
        u = float(d.ctrl[ids.motor]) if command is None else float(command)
        n = max(1, int(round(settle_s / self.physics_dt_s)))
        grip = 0.0
        for _ in range(max_iter):
            d.ctrl[ids.motor] = u
            mujoco.mj_step(m, d, n)
            grip = read_contacts(m, d, ids, self._contacts).grip_force_n
            if grip <= 0:
                raise GraspFailedError(f"hold_grip: no thumb contact with command {u:.4f}")
            if abs(grip - grip_force_n) <= tol * grip_force_n:
                return u
            u = float(np.clip(u * grip_force_n / grip, -1.0, 1.0))
        raise GraspFailedError(
            f"hold_grip: grip {grip:.3f} N after {max_iter} corrections, "
            f"expected {grip_force_n:.3f} N within {tol:.0%}"
        )
