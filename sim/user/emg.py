"""The interface shared by the sEMG generators.

A generator turns per-muscle neural drive into each muscle's sEMG (as the
front end and ADC sampling see it, aliasing included) and each muscle's force.
The subject then mixes the sEMG onto the electrodes (:mod:`sim.user.armband`) and
sums the forces into grip force. Both implementations,
:class:`sim.user.emg_noise.NoiseEmgGenerator` and
:class:`sim.user.motor_units.MotorUnitEmgGenerator`, satisfy :class:`EmgGenerator`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Protocol, runtime_checkable

import numpy as np

from sim.user.armband import FrontEnd
from sim.user.muscles import MuscleParams


@dataclass(frozen=True)
class MuscleSignals:
    """What the muscles produce, sampled at the ADC rate.

    Attributes
    ----------
    emg : ndarray, shape (n_samples, n_muscles)
        Each muscle's sEMG after the front end and sampling, scaled so that
        its RMS is about 1 at full drive (multiply by ``amplitude_lsb``).
    force : ndarray, shape (n_samples, n_muscles)
        Each muscle's force normalized to its steady force at full drive.
    info : dict
        Generator-specific JSON-ready statistics (e.g. spike counts).
    """

    emg: np.ndarray
    force: np.ndarray
    info: dict[str, Any] = field(default_factory=dict)


@runtime_checkable
class EmgGenerator(Protocol):
    """A model from neural drive to muscle sEMG and force."""

    name: str

    def generate(
        self,
        drive: np.ndarray,
        muscles: MuscleParams,
        front_end: FrontEnd,
        *,
        fs_hz: float,
        rng: np.random.Generator,
    ) -> MuscleSignals:
        """Muscle sEMG and force for a drive of shape (n_samples, n_muscles) at ``fs_hz``."""
        ...

    def steady_force(self, drive: np.ndarray, muscles: MuscleParams) -> np.ndarray:
        """Normalized steady muscle force at constant drive, shape (n_muscles,)."""
        ...

    def params(self) -> dict[str, Any]:
        """JSON-ready generator settings for recording metadata."""
        ...


class CausalMuscles(Protocol):
    """A generator's state while it turns drive into sEMG and force chunk by chunk.

    The two are separate streams, each fed every sample of drive once, in
    order, in chunks of any size: a user in the loop needs the sEMG at every
    feature window and the force only when something reads it.
    """

    def emg(self, drive: np.ndarray) -> np.ndarray:
        """Muscle sEMG of the next chunk of drive, both shape (n_chunk, n_muscles)."""
        ...

    def force(self, drive: np.ndarray) -> np.ndarray:
        """Muscle force of the next chunk of drive, both shape (n_chunk, n_muscles)."""
        ...


@runtime_checkable
class CausalEmgGenerator(EmgGenerator, Protocol):
    """An :class:`EmgGenerator` that can also run causally (an optional capability).

    ``causal(n_samples, ...)`` draws everything that does not depend on the
    drive for a recording of ``n_samples`` from ``rng`` up front, in the order
    :meth:`EmgGenerator.generate` draws it, and returns a :class:`CausalMuscles`
    whose chunks, fed the same drive, equal ``generate``'s output. A reacting
    user (:mod:`sim.user.operator`), whose drive depends on what the hand did,
    needs it; generators without it run only with a scripted user.
    """

    def causal(
        self,
        n_samples: int,
        muscles: MuscleParams,
        front_end: FrontEnd,
        *,
        fs_hz: float,
        rng: np.random.Generator,
    ) -> CausalMuscles:
        """State for ``n_samples`` of causal generation (noise drawn up front)."""
        ...


def is_causal(generator: object) -> bool:
    """Whether ``generator`` offers :meth:`CausalEmgGenerator.causal`."""
    return callable(getattr(generator, "causal", None))
