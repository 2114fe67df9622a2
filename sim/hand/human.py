"""The intact hand as griploop simulates it: the same digits, pre-shaped and at human speed.

griploop has one MuJoCo hand. The intact-hand reference (estimator ``intact``) runs it as a
person's own hand in the two ways reach-to-grasp studies measure, with the user's own grip
force as its reference at every control step (no sEMG path):

**Pre-shaped.** During the reach the hand opens to a maximum grip aperture a little wider
than the object, reached at about 60-75 % of the movement, and closes on the object in the
remaining ~30 % (Jeannerod 1984, J Motor Behav 16:235; reviewed by Smeets & Brenner 1999,
Motor Control 3:237: the maximum aperture in precision grasps is about the object's width
plus 2-3 cm). A trial starts with the arm at the object (the reach is over), so the digits
start at the pre-shape: :data:`PRESHAPE_APERTURE_M` (2.5 cm, the middle of 2-3 cm) wider
than the object, summed over both sides (:class:`sim.hand.env_spec.GraspTask`'s
``preshape_aperture_m``; :class:`~sim.hand.grasp_env.GraspEnv` finds the digit angle from
the pads' distance to the object at reset). They open no wider than the pre-shape during
the trial: a person lets go of a block by opening to about the aperture they grasped it
with, not to the hand's full span.

**Closing in human time.** The last ~30 % of a 0.5-0.8 s reach (Jeannerod 1984) is
0.15-0.25 s: :data:`CLOSING_S` = 0.2 s, the middle. The hand closes under its controller's
closing command (:attr:`controllers.design_spec.DesignSpec.closing_command`, 0.2 of the
motor's voltage, until the first touch), at that fraction of the motor's no-load speed.
:func:`human_motor` sets the no-load speed so that the fingertips, which lead the closing
(the pads meet an object first with their tips, :data:`CLOSING_LEVER_M`), cover half the
pre-shape's extra aperture per side in :data:`CLOSING_S`: 1562.5 rad/s at the motor against
the prosthesis's 1480 (the prosthesis's free full close is 0.56 s over its full span; from
the pre-shape it was already close to human time, and is slow in trials because it starts
fully open). Stall torque, gearbox and inertia are the prosthesis's. Nothing here is fitted
to a trial's outcome.
"""

from __future__ import annotations

from dataclasses import replace

from sim.hand.env_spec import GraspTask, HandSpec
from sim.hand.errors import HandSpecError
from sim.hand.model import DRIVE_COEF, FINGER_LENGTH_M, MotorSpec

PRESHAPE_APERTURE_M = 0.025
"""The pre-shape's aperture beyond the object's width, both sides together, m: the maximum
grip aperture of precision grasps exceeds the object's width by about 2-3 cm (Jeannerod 1984;
Smeets & Brenner 1999)."""
CLOSING_S = 0.2
"""How long the digits take to close from the pre-shape onto the object, s: the last ~30 %
of a 0.5-0.8 s reach-to-grasp movement, 0.15-0.25 s (Jeannerod 1984)."""
CLOSING_LEVER_M = FINGER_LENGTH_M
"""Distance from a digit's hinge to the point that meets the object first, m: the fingertip
(the digits are tilted inwards as they close, so their tips lead)."""


def human_motor(closing_command: float, base: MotorSpec | None = None) -> MotorSpec:
    """The intact hand's drive: ``base`` with the no-load speed that closes the pre-shape's gap
    in :data:`CLOSING_S` at ``closing_command`` (module notes).

    Per side the gap is half of :data:`PRESHAPE_APERTURE_M`; the fingertip closes it at
    ``CLOSING_LEVER_M * q_dot``, and the coupled digit angle turns at ``q_dot = c * v_0 /
    sum(DRIVE_COEF)`` at command ``c`` (the tendon ``L = 0.5 q_i + 0.5 q_m + q_t`` moves
    2 rad per rad of the coupled angle), ``v_0`` the tendon's no-load speed.

    Parameters
    ----------
    closing_command : float
        The controller's normalized command while closing (0..1].
    base : MotorSpec, optional
        The motor whose speed is set (default: the prosthesis's, ``MotorSpec()``).

    Raises
    ------
    HandSpecError
        A closing command outside (0, 1].
    """
    if not 0.0 < closing_command <= 1.0:
        raise HandSpecError(f"closing_command: expected 0 < c <= 1, found {closing_command!r}")
    base = MotorSpec() if base is None else base
    digit_rad_s = 0.5 * PRESHAPE_APERTURE_M / CLOSING_S / CLOSING_LEVER_M
    tendon_rad_s = digit_rad_s * sum(DRIVE_COEF.values()) / closing_command
    return replace(base, no_load_speed_rad_s=tendon_rad_s * base.gear_ratio)


def human_hand(closing_command: float) -> HandSpec:
    """The intact hand's :class:`~sim.hand.env_spec.HandSpec`: backdrivable,
    :func:`human_motor`'s drive."""
    return HandSpec(drive="backdrivable", motor=human_motor(closing_command))


def human_task(episode_s: float) -> GraspTask:
    """The intact hand's episode: ``episode_s`` long, the digits starting pre-shaped."""
    return GraspTask(episode_s=episode_s, preshape_aperture_m=PRESHAPE_APERTURE_M)
