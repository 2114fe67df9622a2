"""The virtual user: muscles, sEMG generators, armband, FSR and grip-intent protocols.

A :class:`~sim.user.subjects.VirtualSubject` turns an intended grip-force
profile (:mod:`sim.user.intent`) into muscle drive (:mod:`sim.user.muscles`),
multichannel sEMG from an :class:`~sim.user.emg.EmgGenerator`
(:mod:`sim.user.emg_noise`, :mod:`sim.user.motor_units`; named in
:mod:`sim.user.generators`), the armband's
crosstalk and int8 quantization (:mod:`sim.user.armband`) and an FSR force
reading (:mod:`sim.user.fsr`), returned as a :class:`sim.recording.Recording`.

May import: numpy, scipy, :mod:`sim.recording`, :mod:`sim.registry`. Never :mod:`sim.hand`.
"""
