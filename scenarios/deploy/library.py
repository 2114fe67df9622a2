"""An export compiled on the host, loaded with ctypes: C features, estimator and controller.

Each wrapper owns its C state (a buffer of the size the library reports) and
offers the Python protocol of what it replaces: :class:`CompiledFeatures` pushes
int8 frames, :class:`CompiledStream` is an estimator stream (``reset``, ``step(u,
y_prev)``), :class:`CompiledReference` shapes the hand reference from the estimate
(``reset``, ``step(estimate_n)``; with a decoder ``step(estimate_n, close, open)`` and the
paradigm's ``command_range``), :class:`CompiledController` is a runtime controller
(``reset``, ``act(observation)``), :class:`CompiledDecoderWindow` and
:class:`CompiledDecoder` are the open/close decoder's MAV window and state machine.
Values cross as the library's real type (float32 unless
built with ``GRIPLOOP_DOUBLE``).
"""

from __future__ import annotations

import ctypes
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from controllers.base import Observation, as_observation


class ObservationStruct(ctypes.Structure):
    """``griploop_observation`` (float32 build)."""

    _fields_ = [("reference_n", ctypes.c_float), ("grip_force_n", ctypes.c_float),
                ("finger_velocity", ctypes.c_float), ("slip_speed_m_s", ctypes.c_float),
                ("thumb_contact", ctypes.c_uint8), ("finger_contact", ctypes.c_uint8)]


class CompiledLibrary:
    """A loaded export (``griploop_*`` symbols of one shared library).

    Parameters
    ----------
    path : Path
        The shared library (:func:`scenarios.deploy.build.compile_shared`).
    """

    def __init__(self, path: Path) -> None:
        self.path = Path(path)
        self.lib = ctypes.CDLL(str(self.path))
        self.has_controller = hasattr(self.lib, "griploop_controller_act")
        self.has_decoder = hasattr(self.lib, "griploop_decoder_step")
        self._declare()

    def _declare(self) -> None:
        f, lib = ctypes.c_float, self.lib
        for part in ("features", "estimator", "reference", "controller"):
            if part == "controller" and not self.has_controller:
                continue
            getattr(lib, f"griploop_{part}_state_size").restype = ctypes.c_uint32
            getattr(lib, f"griploop_{part}_reset").restype = None
        lib.griploop_features_push.restype = ctypes.c_int
        lib.griploop_features_push.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p]
        lib.griploop_estimator_step.restype = f
        lib.griploop_estimator_step.argtypes = [ctypes.c_void_p, ctypes.c_void_p, f]
        lib.griploop_reference_step.restype = f
        lib.griploop_reference_step.argtypes = [ctypes.c_void_p, f, f, f] if \
            self.has_decoder else [ctypes.c_void_p, f]
        if self.has_decoder:
            lib.griploop_decoder_window_state_size.restype = ctypes.c_uint32
            lib.griploop_decoder_window_reset.restype = None
            lib.griploop_decoder_window_push.restype = ctypes.c_int
            lib.griploop_decoder_window_push.argtypes = [ctypes.c_void_p] * 3
            lib.griploop_decoder_reset.restype = None
            lib.griploop_decoder_step.restype = None
            lib.griploop_decoder_step.argtypes = [ctypes.c_void_p] * 3
            lib.griploop_decoder_label.restype = ctypes.c_int32
            lib.griploop_reference_command_range.restype = None
            lib.griploop_reference_command_range.argtypes = [ctypes.c_void_p] * 3
        if self.has_controller:
            lib.griploop_controller_act.restype = f
            lib.griploop_controller_act.argtypes = [ctypes.c_void_p,
                                                    ctypes.POINTER(ObservationStruct)]
            lib.griploop_controller_core_reference.restype = f
            lib.griploop_controller_phase.restype = ctypes.c_int32

    def state(self, part: str) -> ctypes.Array:
        """A zeroed state buffer of ``part`` (``features``, ``estimator``, ``reference``,
        ``controller``, ``decoder_window``)."""
        size = int(getattr(self.lib, f"griploop_{part}_state_size")())
        return (ctypes.c_uint64 * ((size + 7) // 8))()  # 8-byte aligned


class CompiledFeatures:
    """The C feature window: :meth:`push` one int8 frame, features when a window ends."""

    def __init__(self, library: CompiledLibrary, n_features: int) -> None:
        self._lib = library.lib
        self._state = library.state("features")
        self._out = np.zeros(n_features, dtype=np.float32)
        self._out_ptr = self._out.ctypes.data_as(ctypes.c_void_p)
        self.reset()

    def reset(self) -> None:
        """Forget every sample."""
        self._lib.griploop_features_reset(self._state)

    def push(self, frame: np.ndarray) -> np.ndarray | None:
        """One frame (int8, all armband channels); the window's features or ``None``."""
        frame = np.ascontiguousarray(frame, dtype=np.int8)
        ready = self._lib.griploop_features_push(self._state, frame.ctypes.data_as(
            ctypes.c_void_p), self._out_ptr)
        return self._out.copy() if ready else None

    def run(self, emg: np.ndarray) -> np.ndarray:
        """Features of every window of ``emg`` (n_samples, n_armband), shape (n_windows, n)."""
        emg = np.ascontiguousarray(emg, dtype=np.int8)
        rows = [f for f in (self.push(frame) for frame in emg) if f is not None]
        return np.array(rows, dtype=np.float32).reshape(len(rows), self._out.size)


class CompiledStream:
    """The C estimator as an estimator stream: raw features and N in, N out."""

    def __init__(self, library: CompiledLibrary, *, mode: str, uses_force: bool) -> None:
        self._lib = library.lib
        self._state = library.state("estimator")
        self.mode = mode
        self.uses_force = uses_force
        self._u = None
        self.reset()

    def reset(self) -> None:
        """Back to the start of a session."""
        self._lib.griploop_estimator_reset(self._state)

    def step(self, u: np.ndarray, y_prev: float | None = None) -> float:
        """Features ``u(k)`` (and ``y(k-1)``, N); the estimate, N."""
        u32 = np.ascontiguousarray(u, dtype=np.float32)
        return float(self._lib.griploop_estimator_step(
            self._state, u32.ctypes.data_as(ctypes.c_void_p),
            0.0 if y_prev is None else float(y_prev)))


class CompiledReference:
    """The runtime's hand reference: rest threshold, force mapping and paradigm, in C."""

    def __init__(self, library: CompiledLibrary) -> None:
        self._lib = library.lib
        self._decoded = library.has_decoder
        self._state = library.state("reference")
        self.reset()

    def reset(self) -> None:
        """Open, as at rest."""
        self._lib.griploop_reference_reset(self._state)

    def step(self, estimate_n: float, close: float = 0.0, open_: float = 0.0) -> float:
        """One window's estimate (user N) and, with a decoder, its close and open levels;
        the hand reference, N."""
        if self._decoded:
            return float(self._lib.griploop_reference_step(self._state, float(estimate_n),
                                                           float(close), float(open_)))
        return float(self._lib.griploop_reference_step(self._state, float(estimate_n)))

    def command_range(self) -> tuple[float, float]:
        """The bounds the paradigm put on the motor command at the last step (with a
        decoder; ``(-1, 1)`` without one)."""
        if not self._decoded:
            return (-1.0, 1.0)
        lo, hi = ctypes.c_float(), ctypes.c_float()
        self._lib.griploop_reference_command_range(self._state, ctypes.byref(lo),
                                                   ctypes.byref(hi))
        return float(lo.value), float(hi.value)

    def run(self, estimates_n: np.ndarray) -> np.ndarray:
        """:meth:`step` over a sequence, from the current state, shape (n,)."""
        return np.array([self.step(v) for v in np.asarray(estimates_n, dtype=float)])


class CompiledController:
    """The C runtime controller: ``reset()`` and ``act(observation) -> command``.

    Attributes
    ----------
    dt_s : float
        Control period of the design, s.
    """

    def __init__(self, library: CompiledLibrary, *, dt_s: float, name: str) -> None:
        self._lib = library.lib
        self._state = library.state("controller")
        self._obs = ObservationStruct()
        self._obs_ref = ctypes.byref(self._obs)
        self.dt_s = float(dt_s)
        self.name = name
        self.reset()

    def reset(self) -> None:
        """Start of a grasp."""
        self._lib.griploop_controller_reset(self._state)

    def act(self, observation: Observation | Mapping[str, Any]) -> float:
        """The motor command (-1..1) for an observation."""
        obs = as_observation(observation)
        o = self._obs
        o.reference_n = obs.reference_n
        o.grip_force_n = obs.grip_force_n
        o.finger_velocity = obs.finger_velocity
        o.slip_speed_m_s = obs.slip_speed_m_s
        o.thumb_contact = bool(obs.thumb_contact)
        o.finger_contact = bool(obs.finger_contact)
        return float(self._lib.griploop_controller_act(self._state, self._obs_ref))

    @property
    def last_reference_n(self) -> float:
        """The reference the force loop tracked at the last step, N."""
        return float(self._lib.griploop_controller_core_reference(self._state))

    @property
    def phase(self) -> int:
        """The gate's phase (0 closing, 1 approach, 2 force, 3 releasing, 4 open)."""
        return int(self._lib.griploop_controller_phase(self._state))


class CompiledDecoderWindow:
    """The decoder's C window: :meth:`run` gives the MAV of every channel per window."""

    def __init__(self, library: CompiledLibrary, n_channels: int) -> None:
        self._lib = library.lib
        self._state = library.state("decoder_window")
        self._out = np.zeros(n_channels, dtype=np.float32)
        self._out_ptr = self._out.ctypes.data_as(ctypes.c_void_p)
        self._lib.griploop_decoder_window_reset(self._state)

    def run(self, emg: np.ndarray) -> np.ndarray:
        """MAV rows of every window of ``emg`` (n_samples, n_armband) int8, from a reset,
        shape (n_windows, n_armband)."""
        self._lib.griploop_decoder_window_reset(self._state)
        emg = np.ascontiguousarray(emg, dtype=np.int8)
        rows = []
        for frame in emg:
            if self._lib.griploop_decoder_window_push(
                    self._state, frame.ctypes.data_as(ctypes.c_void_p), self._out_ptr):
                rows.append(self._out.copy())
        return np.array(rows, dtype=np.float32).reshape(len(rows), self._out.size)


class CompiledDecoder:
    """The C open/close decoder (state in the library's statics: one per library)."""

    def __init__(self, library: CompiledLibrary) -> None:
        self._lib = library.lib
        self._close, self._open = ctypes.c_float(), ctypes.c_float()
        self.reset()

    def reset(self) -> None:
        """Back to rest."""
        self._lib.griploop_decoder_reset()

    def step(self, mav: np.ndarray) -> tuple[float, float, int]:
        """One window's MAV of every channel; ``(close, open, label)``."""
        row = np.ascontiguousarray(mav, dtype=np.float32)
        self._lib.griploop_decoder_step(row.ctypes.data_as(ctypes.c_void_p),
                                        ctypes.byref(self._close), ctypes.byref(self._open))
        return (float(self._close.value), float(self._open.value),
                int(self._lib.griploop_decoder_label()))
