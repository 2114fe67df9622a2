"""A virtual subject recorded causally: sEMG and force chunk by chunk, as the intent arrives.

:meth:`sim.user.subjects.VirtualSubject.record` turns a whole intent profile into
a whole recording. A user who reacts to the hand changes the intent while the
episode runs, so the recording has to be produced causally. :class:`CausalSession`
does it without changing a single sample:

1. everything that does not depend on the intent is drawn up front, for the
   whole session, from the session's generator and *in the order* ``record``
   draws it: the drive fluctuation ``eta`` (Ornstein-Uhlenbeck) and the
   co-contraction drift (both turned into targets by
   :func:`sim.user.muscles.drive_targets`, as ``record`` does), the generator's carrier
   noise and its Laplace mixture (:meth:`sim.user.emg.CausalEmgGenerator.causal`), the
   sEMG gain fluctuation ``xi``, the electrodes' noise (drifting floor and contact bursts,
   :meth:`sim.user.armband.Armband.electrode_noise_lsb`), the FSR's contact fluctuation and
   its ADC noise (the rig's stream lag applies to calibration recordings only);
2. each chunk of intent then becomes drive and muscle sEMG, mixed and
   quantized by the subject's own armband (:meth:`sim.user.armband.Armband.quantize`);
   the muscle force, grip force and FSR reading follow only when something
   reads them (:meth:`CausalSession.read_forces`), with every filter state
   carried between chunks (the electromechanical delay's history and the
   activation dynamics' ``lfilter`` state) and the FSR's own code fed the
   pre-drawn noise.

An open intent (``advance(intent, open_intent)``) adds the subject's opening pattern to
the sEMG's drive and nothing to the force's, as ``record`` does with a profile's
``open_intent``. Fed the intent of a profile in any chunks, a session gives ``record``'s sEMG
and forces exactly (``tests/sim/test_causal.py``), so a scripted user's
results do not depend on which path produced them. Generators without the
causal capability (the motor-unit pool draws its discharges from the drive
itself) raise :class:`NotCausalError`.
"""

from __future__ import annotations

import numpy as np

from sim.errors import GriploopError
from sim.user.armband import INT8_MAX, INT8_MIN
from sim.user.emg import is_causal
from sim.user.generators import make_generator
from sim.user.muscles import N_MUSCLES, drive_targets, slow_fluctuation, with_opening
from sim.user.subjects import VirtualSubject


class NotCausalError(GriploopError, ValueError):
    """An sEMG generator that cannot run chunk by chunk was asked to."""


class _Replay:
    """Stands in for a ``numpy.random.Generator``: ``standard_normal`` returns pre-drawn values.

    Lets the armband's and the FSR's own code run unchanged on one chunk at a
    time while their noise was drawn for the whole session up front.
    """

    def __init__(self, values: np.ndarray) -> None:
        self._values = values
        self._n = 0

    def standard_normal(self, shape: tuple[int, ...]) -> np.ndarray:
        k = shape[0]
        out = self._values[self._n:self._n + k]
        self._n += k
        return out.reshape(shape)


class CausalSession:
    """A recording session of one subject, produced chunk by chunk.

    Parameters
    ----------
    subject : VirtualSubject
        The user (with any electrode shift, noise or fatigue applied).
    n_samples : int
        Length of the session, samples: every intent-independent noise is
        drawn for this many samples (the same draws ``record`` makes for a
        profile of this length).
    generator : str or EmgGenerator
        An sEMG generator with the causal capability (``noise``).
    fs_hz : float
        Sampling rate in hertz.
    rng : numpy.random.Generator
        The session's noise (consumed here, up front).

    Raises
    ------
    NotCausalError
        The generator cannot run chunk by chunk.
    """

    def __init__(self, subject: VirtualSubject, n_samples: int, *,
                 generator: str = "noise", fs_hz: float = 200.0,
                 rng: np.random.Generator) -> None:
        gen = make_generator(generator)
        if not is_causal(gen):
            raise NotCausalError(
                f"sEMG generator {gen.name} produces a whole recording at once and cannot "
                "follow a reacting user; expected a causal generator (noise), or the "
                "scripted user")
        n = int(n_samples)
        m = subject.muscles
        self.subject = subject
        self.fs_hz = float(fs_hz)
        self.n_samples = n
        # The draws of VirtualSubject.record, in its order, and the factors it makes of them
        # (1 + eta, the clipped sEMG gain 1 + xi: elementwise, the same values).
        self._one_eta = 1.0 + slow_fluctuation(n, fs_hz, m.array("fluctuation_std"),
                                               m.fluctuation_time_s, rng)
        # the co-contraction drift of the muscles that do not grip (VirtualSubject.drive)
        self._others = m.array("grip_share") == 0
        self._cocontraction = None
        if m.cocontraction_drift_std > 0:
            std = np.full(int(self._others.sum()), m.cocontraction_drift_std)
            self._cocontraction = slow_fluctuation(n, fs_hz, std, m.cocontraction_drift_time_s,
                                                   rng)
        self._muscles = gen.causal(n, m, subject.armband.front_end, fs_hz=fs_hz, rng=rng)
        self._gain = np.maximum(1.0 + slow_fluctuation(n, fs_hz, m.array("emg_gain_std"),
                                                       m.emg_gain_time_s, rng), 0.0)
        self._armband_noise = subject.armband.electrode_noise_lsb(n, fs_hz, rng)
        self._mixing_t = subject.armband.mixing_matrix_view(N_MUSCLES).T
        self._contact = slow_fluctuation(n, fs_hz, np.array([subject.contact_std]),
                                         subject.contact_time_s, rng)[:, 0]
        self._fsr_noise = _Replay(rng.standard_normal(n))
        grid = np.repeat(np.linspace(0.0, 1.0, 257)[:, None], N_MUSCLES, axis=1)
        self._grid = np.ascontiguousarray(grid.T).T  # column slices contiguous for np.interp
        self._curve = np.ascontiguousarray(
            np.maximum.accumulate(gen.steady_force(grid, m), axis=0).T).T
        self._shared_curve = bool(np.all(self._curve == self._curve[:, :1])
                                  and np.all(self._grid == self._grid[:, :1]))
        self._synergy = m.array("synergy")
        self._amplitude = m.array("amplitude_lsb")
        share = m.array("grip_share")
        self._share = share
        self._grip_scale = float(self._synergy @ share)
        self._drive = np.empty((n, N_MUSCLES))
        self._grip_n = np.empty(n)
        self._force_n = np.empty(n)
        self._n = 0
        self._n_forces = 0

    @property
    def n_done(self) -> int:
        """Samples produced so far."""
        return self._n

    def advance(self, intent: np.ndarray, open_intent: np.ndarray | None = None
                ) -> np.ndarray:
        """The sEMG of the next chunk of the session, for this chunk of intent.

        The drive of the chunk is kept; :meth:`read_forces` turns it into
        muscle force, grip force and the FSR's reading when they are needed
        (the sEMG never depends on them).

        Parameters
        ----------
        intent : ndarray, shape (n_chunk,)
            Intended grip force as a fraction of MVC (clipped to 0..1).
        open_intent : ndarray, shape (n_chunk,), optional
            Intended opening, 0..1 (``None``: none; clipped to 0..1): it drives the sEMG
            with the subject's opening pattern (:func:`sim.user.muscles.with_opening`) and
            adds nothing to the grip, whose muscle force comes from the close intent's
            drive alone, as in ``record``.

        Returns
        -------
        ndarray of int8, shape (n_chunk, 8)
            The armband's sEMG.

        Raises
        ------
        ValueError
            The session would run past ``n_samples``, or ``open_intent`` is not shaped
            like ``intent``.
        """
        # np.minimum/np.maximum give np.clip's values exactly, for less overhead per chunk
        u = np.minimum(np.maximum(np.asarray(intent, dtype=float), 0.0), 1.0)
        i0, i1 = self._n, self._n + u.size
        if i1 > self.n_samples:
            raise ValueError(f"causal session of {self.n_samples} samples asked for sample {i1}")
        drift = None if self._cocontraction is None else self._cocontraction[i0:i1]
        one_eta = self._one_eta[i0:i1]
        close = drive_targets(self.subject.muscles, u, one_eta, drift)
        if open_intent is None:
            drive = self._inverse(close)
            self._drive[i0:i1] = drive
        else:  # the sEMG of both intents; the grip's force from the close intent's drive
            v = np.minimum(np.maximum(np.asarray(open_intent, dtype=float), 0.0), 1.0)
            if v.shape != u.shape:
                raise ValueError(f"open intent: expected shape {u.shape} like the intent, "
                                 f"found {v.shape}")
            drive = self._inverse(with_opening(self.subject.muscles, close, v, one_eta))
            self._drive[i0:i1] = self._inverse(close)
        # Armband.digitize's steps (mix, noise, round, clip) without its saturation count
        band = self.subject.armband
        muscle_lsb = self._muscles.emg(drive) * self._gain[i0:i1] * self._amplitude
        q = band.quantize(muscle_lsb @ self._mixing_t, self._armband_noise[i0:i1])
        self._n = i1
        return np.clip(q, INT8_MIN, INT8_MAX, out=q).astype(np.int8)

    def _inverse(self, target: np.ndarray) -> np.ndarray:
        """Drive of each muscle for its force target: the steady curve's inverse."""
        grid, curve = self._grid, self._curve
        if self._shared_curve:  # one curve for all muscles (noise): one call, same values
            return np.interp(target.ravel(), curve[:, 0], grid[:, 0]).reshape(target.shape)
        drive = np.empty_like(target)
        for j in range(N_MUSCLES):
            drive[:, j] = np.interp(target[:, j], curve[:, j], grid[:, j])
        return drive

    def read_forces(self) -> tuple[np.ndarray, np.ndarray]:
        """Grip force and FSR reading of every sample produced so far, N.

        Returns
        -------
        grip_n, force_n : ndarray, shape (n_done,)
            The subject's true grip force (before the FSR) and the FSR's
            reading (views; computed once per sample).
        """
        k0, k1 = self._n_forces, self._n
        if k1 > k0:
            s = self.subject
            force = self._muscles.force(self._drive[k0:k1])
            grip = s.mvc_n * (force @ self._share) / self._grip_scale
            contact = 1.0 + self._contact[k0:k1]
            self._grip_n[k0:k1] = grip
            self._force_n[k0:k1] = s.fsr.measure(grip * np.maximum(contact, 0.0),
                                                 self._fsr_noise)
            self._n_forces = k1
        return self._grip_n[:k1], self._force_n[:k1]
