"""The digits pre-shaped to the object at reset: the intact hand's start (:mod:`sim.hand.human`).

:class:`Preshape` finds the coupled digit angle at which the hand's aperture exceeds the
object's width by a given amount, both sides together: the distance from each side's
digit geoms (link and pad) to the object, measured by MuJoCo's own geometry
(``mj_geomDistance``) where the object sits after the reset, and found by bisection
(the gaps shrink monotonically as the digits close). It puts the digits there and moves
their opening stop (the joints' lower range) to that angle, so that an opening command
holds them at the pre-shape instead of opening the hand fully; :meth:`Preshape.clear`
restores the joints' own ranges. Nothing is drawn at random.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from sim.hand.errors import HandSpecError

#: The coupled digits' joints (index, middle and thumb move together: joint equalities).
DIGIT_JOINTS = ("index", "middle", "thumb")
#: The geoms of each side of the grasp: the thumb; the index and middle fingers.
SIDE_GEOMS = (("thumb_link", "thumb_pad"),
              ("index_link", "index_pad", "middle_link", "middle_pad"))
#: Bisection tolerance on the digit angle, rad (a 0.1 mm gap at a 0.1 m fingertip).
ANGLE_TOL_RAD = 1e-3
#: Largest pre-shape aperture beyond the object's width, m.
MAX_APERTURE_M = 0.05


class Preshape:
    """The digits' start pose and opening stop on one compiled hand (module notes).

    Parameters
    ----------
    model : mujoco.MjModel
        A hand made by :func:`sim.hand.model.build_model` (its joint ranges are changed by
        :meth:`apply` and restored by :meth:`clear`).
    """

    def __init__(self, model: mujoco.MjModel) -> None:
        self.model = model
        self.joints = [model.joint(n).id for n in DIGIT_JOINTS]
        self.qpos_adr = [int(model.jnt_qposadr[j]) for j in self.joints]
        self.ranges = [model.jnt_range[j].copy() for j in self.joints]
        self.sides = [[model.geom(g).id for g in side] for side in SIDE_GEOMS]
        self.object_geom = model.geom("object").id
        self.angle_rad: float | None = None

    def aperture_m(self, data: mujoco.MjData, angle_rad: float) -> float:
        """The hand's aperture beyond the object's width at digit angle ``angle_rad``, m
        (the sum of both sides' gaps; negative: the digits would press into it).

        Moves ``data``'s digits to ``angle_rad`` and updates its kinematics.
        """
        for adr in self.qpos_adr:
            data.qpos[adr] = angle_rad
        mujoco.mj_kinematics(self.model, data)
        fromto = np.zeros(6)
        return float(sum(min(mujoco.mj_geomDistance(self.model, data, g, self.object_geom,
                                                    1.0, fromto) for g in side)
                         for side in self.sides))

    def apply(self, data: mujoco.MjData, aperture_m: float) -> float:
        """Pre-shape the digits ``aperture_m`` wider than the object and stop them opening
        further; the digit angle, rad (the hand's widest when even that is too narrow).

        Raises
        ------
        HandSpecError
            An aperture outside 0..:data:`MAX_APERTURE_M`.
        """
        if not (math.isfinite(aperture_m) and 0.0 <= aperture_m <= MAX_APERTURE_M):
            raise HandSpecError(f"preshape_aperture_m: expected 0..{MAX_APERTURE_M} m, "
                                f"found {aperture_m!r}")
        lo, hi = float(self.ranges[0][0]), float(self.ranges[0][1])
        if self.aperture_m(data, lo) <= aperture_m:
            angle = lo
        else:
            while hi - lo > ANGLE_TOL_RAD:  # the aperture shrinks as the digits close
                mid = 0.5 * (lo + hi)
                lo, hi = (mid, hi) if self.aperture_m(data, mid) > aperture_m else (lo, mid)
            angle = lo  # the last angle still at least as wide as asked
        self.aperture_m(data, angle)
        for j, rng in zip(self.joints, self.ranges, strict=True):
            self.model.jnt_range[j] = (angle, rng[1])
        self.angle_rad = angle
        return angle

    def clear(self) -> None:
        """The joints' own ranges back (digits that start straight and open fully)."""
        for j, rng in zip(self.joints, self.ranges, strict=True):
            self.model.jnt_range[j] = rng
        self.angle_rad = None
