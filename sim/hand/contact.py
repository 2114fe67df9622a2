"""Hand-object contact measurement: grip force, load force and slip speed.

Definitions (all from the contacts of the last physics step, vectorized over
``data.contact``; valid for elliptic friction cones, where the first
constraint row of a contact is its normal force):

grip force (N)
    Sum of the contact normal forces between the object and the thumb geoms
    (``thumb_link``, ``thumb_pad``): the force pressing the object against the
    opposing fingers. In static equilibrium it equals the finger-side sum when
    the contact normals are horizontal; it is what a force sensor in the thumb
    pad would read, and the quantity the controllers regulate.
finger force (N)
    The same sum over the index and middle geoms (reported, not regulated).
load force (N)
    Magnitude of the summed tangential (friction) forces the hand applies to
    the object: the weight and inertial load carried by friction. With a
    two-sided grasp the object slips when ``load > mu (grip + finger)``, i.e.
    ``grip / load < 1 / (2 mu)`` (Johansson and Westling's slip ratio).
lift force (N)
    Upward component of the summed contact force (normal and friction) the
    hand applies to the object: the object's weight and vertical inertial load
    while it is carried, negative while the digits press it into the table.
    What a wrist load cell reads, less the hand's own weight.
slip speed (m/s)
    Largest relative tangential velocity between object and digit at the
    hand-object contact points: the friction rows of ``efc_vel = J qvel``,
    computed by MuJoCo in the contact frame.

:func:`first_contact_peak` measures the impact when the hand closes on an
object at a constant command, substep by substep, from the same readings.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco

from sim.hand.errors import GraspFailedError, HandSpecError
from sim.hand.model import HandIds


@dataclass
class ContactReading:
    """Hand-object contact state of one physics step.

    Attributes
    ----------
    grip_force_n : float
        Thumb-side normal force sum, N.
    finger_force_n : float
        Finger-side (index + middle) normal force sum, N.
    load_force_n : float
        Magnitude of the summed tangential force on the object, N.
    lift_force_n : float
        Upward component of the summed hand-object contact force, N.
    slip_speed_m_s : float
        Largest tangential relative speed at a hand-object contact, m/s.
    n_contacts : int
        Number of hand-object contacts.
    thumb_contact, finger_contact : bool
        Whether each side touches the object.
    """

    grip_force_n: float = 0.0
    finger_force_n: float = 0.0
    load_force_n: float = 0.0
    lift_force_n: float = 0.0
    slip_speed_m_s: float = 0.0
    n_contacts: int = 0
    thumb_contact: bool = False
    finger_contact: bool = False


def read_contacts(model: mujoco.MjModel, data: mujoco.MjData, ids: HandIds,
                  out: ContactReading | None = None) -> ContactReading:
    """Measure hand-object contact forces and slip from ``data``.

    Parameters
    ----------
    model, data : MuJoCo model and data after ``mj_step`` or ``mj_forward``.
    ids : HandIds
        Resolved ids of the model.
    out : ContactReading, optional
        Reused in place to avoid allocation in the step loop.

    Returns
    -------
    ContactReading
    """
    out = out if out is not None else ContactReading()
    if data.ncon == 0:
        _zero(out)
        return out
    # Plain Python over the few contacts (a grasp has 2-8, the table adds a few)
    # beats numpy, whose per-call overhead (~0.5 us) exceeds a contact's work.
    # Every MuJoCo array is fetched once as a list (the constraint rows too: a
    # grasp has a few dozen, and list indexing is cheaper than ndarray.item);
    # the pair table is a dict.
    con = data.contact
    pair_get = ids.pair_side.get
    grip = finger = lx = ly = lz = nz = slip2 = 0.0
    n_hits = 0
    thumb = fing = False
    adr = frame = efc_f = efc_v = None
    for i, (g1, g2) in enumerate(con.geom.tolist()):
        hit = pair_get((g1, g2))
        if hit is None:
            continue
        if adr is None:
            adr = con.efc_address.tolist()
            frame = con.frame.tolist()
            efc_f = data.efc_force.tolist()
            efc_v = data.efc_vel.tolist()
        side, sign = hit
        n_hits += 1
        # Elliptic cones: rows a, a+1, a+2 are the normal and the two tangent
        # directions of the contact frame (forces act on geom2).
        a = adr[i]
        f0 = efc_f[a]
        if side == 1:
            grip += f0
            thumb = True
        else:
            finger += f0
            fing = True
        f1 = sign * efc_f[a + 1]
        f2 = sign * efc_f[a + 2]
        fr = frame[i]
        lx += f1 * fr[3] + f2 * fr[6]
        ly += f1 * fr[4] + f2 * fr[7]
        lz += f1 * fr[5] + f2 * fr[8]
        nz += sign * f0 * fr[2]
        # Relative tangential velocity: the friction rows of efc_vel = J qvel.
        v1 = efc_v[a + 1]
        v2 = efc_v[a + 2]
        v = v1 * v1 + v2 * v2
        if v > slip2:
            slip2 = v
    if not n_hits:
        _zero(out)
        return out
    out.grip_force_n = grip
    out.finger_force_n = finger
    out.load_force_n = math.sqrt(lx * lx + ly * ly + lz * lz)
    out.lift_force_n = lz + nz
    out.slip_speed_m_s = math.sqrt(slip2)
    out.n_contacts = n_hits
    out.thumb_contact = thumb
    out.finger_contact = fing
    return out


def _zero(out: ContactReading) -> None:
    out.grip_force_n = 0.0
    out.finger_force_n = 0.0
    out.load_force_n = 0.0
    out.lift_force_n = 0.0
    out.slip_speed_m_s = 0.0
    out.n_contacts = 0
    out.thumb_contact = False
    out.finger_contact = False


class OutcomeTracker:
    """Slip events, slip distance, drop and crush over one episode.

    Parameters
    ----------
    slip_threshold_m_s : float
        Contact slip speed above which the grasp is slipping. A slip event is a
        rising crossing of this threshold while the hand touches the object; it
        counts once until the speed falls below half the threshold (hysteresis)
        or contact is lost.
    drop_distance_m : float
        The object is dropped when no digit touches it and it has moved more
        than this from its starting position in the palm frame.
    break_force_n : float or None
        Crush threshold on the larger of the thumb- and finger-side normal sums.

    Attributes
    ----------
    slip_events : int
        Number of slip events so far.
    slip_distance_m : float
        Path length (m) of the object centre relative to the palm while the
        hand touches the object, accumulated step by step.
    dropped, crushed : bool
        Latched outcomes.
    """

    def __init__(self, slip_threshold_m_s: float = 0.005, drop_distance_m: float = 0.03,
                 break_force_n: float | None = None) -> None:
        if not slip_threshold_m_s > 0:
            raise HandSpecError(
                f"slip_threshold_m_s: expected a positive speed, found {slip_threshold_m_s!r}"
            )
        if not drop_distance_m > 0:
            raise HandSpecError(
                f"drop_distance_m: expected a positive distance, found {drop_distance_m!r}"
            )
        self.slip_threshold_m_s = float(slip_threshold_m_s)
        self.drop_distance_m = float(drop_distance_m)
        self.break_force_n = break_force_n
        self.reset((0.0, 0.0, 0.0))

    def reset(self, rel_pos_m: tuple[float, float, float]) -> None:
        """Start an episode with the object at ``rel_pos_m`` in the palm frame (m)."""
        self.start = tuple(float(v) for v in rel_pos_m)
        self.prev = self.start
        self.slip_events = 0
        self.slip_distance_m = 0.0
        self.slipping = False
        self.dropped = False
        self.crushed = False
        self.displacement_m = 0.0

    def update(self, reading: ContactReading, rel_pos_m: tuple[float, float, float]) -> None:
        """Account one control step given the contact reading and the object position.

        Parameters
        ----------
        reading : ContactReading
            Contacts of the step.
        rel_pos_m : tuple of 3 floats
            Object centre in the palm frame, m.
        """
        x, y, z = rel_pos_m
        px, py, pz = self.prev
        sx, sy, sz = self.start
        touching = reading.n_contacts > 0
        if touching:
            self.slip_distance_m += math.sqrt((x - px) ** 2 + (y - py) ** 2 + (z - pz) ** 2)
            if not self.slipping and reading.slip_speed_m_s > self.slip_threshold_m_s:
                self.slipping = True
                self.slip_events += 1
        if self.slipping and (not touching
                              or reading.slip_speed_m_s < 0.5 * self.slip_threshold_m_s):
            self.slipping = False
        self.prev = (x, y, z)
        self.displacement_m = math.sqrt((x - sx) ** 2 + (y - sy) ** 2 + (z - sz) ** 2)
        if reading.n_contacts == 0 and self.displacement_m > self.drop_distance_m:
            self.dropped = True
        if self.break_force_n is not None and max(
            reading.grip_force_n, reading.finger_force_n
        ) > self.break_force_n:
            self.crushed = True


@dataclass(frozen=True)
class FirstContact:
    """Contact forces when the hand closes on an object at a constant command.

    Forces are the larger of the thumb-side and finger-side normal sums (the
    crush criterion), read at every physics substep.

    Attributes
    ----------
    closing_command : float
        Normalized motor command applied throughout.
    touch_time_s : float
        Time of the first hand-object contact, s.
    grasp_time_s : float
        Time at which both sides first touch the object, s.
    peak_force_n : float
        Largest force from the first touch until ``window_s`` after the grasp
        forms, N: the impact a contact-triggered controller reacting within
        ``window_s`` cannot prevent.
    hold_peak_force_n : float
        Largest force over the whole run (command held ``hold_s`` after the
        grasp forms), N.
    settled_force_n : float
        Force at the end of the run, N: the quasi-static squeeze at this command.
    window_s, hold_s : float
        The windows used, s.
    """

    closing_command: float
    touch_time_s: float
    grasp_time_s: float
    peak_force_n: float
    hold_peak_force_n: float
    settled_force_n: float
    window_s: float
    hold_s: float

    @property
    def overshoot(self) -> float:
        """``hold_peak_force_n / settled_force_n``: 1 when there is no impact transient."""
        return self.hold_peak_force_n / self.settled_force_n


def first_contact_peak(model: mujoco.MjModel, data: mujoco.MjData, ids: HandIds,
                       closing_command: float, *, window_s: float = 0.02,
                       hold_s: float = 1.0, max_close_s: float = 3.0) -> FirstContact:
    """Close the hand at a constant command and measure the first-contact forces.

    The command is applied from the current state (the open hand around the
    object, e.g. just after ``GraspEnv.reset``) and held: before contact as
    the closing command of a contact gate, after it as the command the gate
    holds until its controller reacts. ``data`` is advanced in place.

    Parameters
    ----------
    model, data : MuJoCo model and data of :func:`sim.hand.model.build_model`.
    ids : HandIds
        Resolved ids of the model.
    closing_command : float
        Normalized motor command in (0, 1].
    window_s : float
        Reaction window after the grasp forms, s (default two 10 ms control
        periods: contact seen at the end of one, new command in the next).
    hold_s : float
        How long the command is held after the grasp forms, s (>= ``window_s``;
        the default lets the squeeze settle, its time constant on the pads
        being about 0.2 s).
    max_close_s : float
        Time allowed for the grasp to form, s.

    Returns
    -------
    FirstContact

    Raises
    ------
    ValueError
        If a parameter is out of range.
    RuntimeError
        If both sides do not touch the object within ``max_close_s``.
    """
    if not 0 < closing_command <= 1:
        raise HandSpecError(f"closing_command: expected 0 < c <= 1, found {closing_command!r}")
    if not 0 < window_s <= hold_s:
        raise HandSpecError(
            f"window_s, hold_s: expected 0 < window_s <= hold_s, found {window_s!r}, {hold_s!r}"
        )
    if not max_close_s > 0:
        raise HandSpecError(f"max_close_s: expected a positive duration, found {max_close_s!r}")
    dt = model.opt.timestep
    data.ctrl[ids.motor] = closing_command
    reading = ContactReading()
    t_start = data.time
    touch = grasp = None
    peak = hold_peak = force = 0.0
    while True:
        mujoco.mj_step(model, data)
        read_contacts(model, data, ids, reading)
        t = data.time
        force = max(reading.grip_force_n, reading.finger_force_n)
        if touch is None and reading.n_contacts:
            touch = t
        if grasp is None and reading.thumb_contact and reading.finger_contact:
            grasp = t
        hold_peak = max(hold_peak, force)
        if touch is not None and (grasp is None or t <= grasp + window_s + 0.5 * dt):
            peak = max(peak, force)
        if grasp is not None and t >= grasp + hold_s - 0.5 * dt:
            break
        if grasp is None and t - t_start > max_close_s:
            raise GraspFailedError(
                f"first_contact_peak: expected a grasp within {max_close_s} s at command "
                f"{closing_command}, found no two-sided contact"
            )
    return FirstContact(closing_command=float(closing_command), touch_time_s=float(touch),
                        grasp_time_s=float(grasp), peak_force_n=peak,
                        hold_peak_force_n=hold_peak, settled_force_n=force,
                        window_s=float(window_s), hold_s=float(hold_s))
