"""The virtual user: muscles, sEMG generators, armband, FSR and grip-intent protocols.

A :class:`~sim.user.subjects.VirtualSubject` turns an intended grip-force
profile (:mod:`sim.user.intent`) into muscle drive (:mod:`sim.user.muscles`),
multichannel sEMG from an :class:`~sim.user.emg.EmgGenerator`
(:mod:`sim.user.emg_noise`, :mod:`sim.user.motor_units`; named in
:mod:`sim.user.generators`), the armband's
crosstalk and int8 quantization (:mod:`sim.user.armband`) and an FSR force
reading (:mod:`sim.user.fsr`), returned as a :class:`sim.recording.Recording`;
:mod:`sim.user.causal` produces the same recording chunk by chunk, as a user in the
loop decides. The person behind the intent is an operator model
(:mod:`sim.user.operator`: perception channels, corrections, anticipation, motor
noise) with an optional feedback mode (:mod:`sim.user.feedback`), both named in
:mod:`sim.user.operators`; it perceives the hand only as plain numbers the runner
passes (:class:`sim.user.operator.Scene`).

May import: numpy, scipy, :mod:`sim.recording`, :mod:`sim.registry`. Never :mod:`sim.hand`.
"""
