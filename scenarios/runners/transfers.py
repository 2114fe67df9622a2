"""Timed transfers: the Box and Blocks Test as published, blocks moved per minute.

**The published test** (Mathiowetz et al. 1985, Am J Occup Ther 39:386): a person moves
2.5 cm wooden cubes one at a time over a 15.2 cm partition for 60 s; a block counts
once it has been carried over the partition and let go, and a block dropped on the far
side after it was carried over counts too; one dropped before the partition does not.
Young adults move 79-89 blocks per minute with the dominant hand (Niama Natta et al.
2015); experienced transradial myoelectric users 15-21 (CALIBRATION.md, "Practised
users").

Kind ``transfers`` (protocol ``timed_transfers``): one practised user grasps the block
(``bbt_cube`` by default: the test's 25 mm cube, :mod:`sim.hand.objects`), lifts it over
the partition and puts it down beyond, again and again, until ``protocol.duration_s``
has passed. Each transfer is a trial the user paces (:mod:`sim.user.reacting`): they
close the hand, lift when the grip looks secure, try again when the block stays behind,
carry it over and let go. The carry is one arm movement of ``protocol.transport_s`` (up
to :data:`PARTITION_CLEARANCE_M` in half of it, down in the other half) and between
transfers the arm reaches back for the next block in ``protocol.reach_s``; either left
at ``None`` is the user's ``lift_s`` (0.6 s: natural reach and transport movements take
about 0.5-0.8 s, Jeannerod 1984). These movement times come from people, never from the
score. Published phase durations of the Box and Blocks Test (for intact people and for
prosthesis users, whose phases are longer) are not the defaults yet: they could not be
read from their sources when these fields were added (docs/results/person-in-the-loop.md,
"Timed transfers").

**Raveh et al.'s untimed test** (``protocol.blocks``; Raveh et al. 2018, Arch Phys Med
Rehabil 99:2263, a modified Box and Blocks test without vision): the user moves a set
number of blocks (16), each once, whatever becomes of it, and the test reports the time
per block (the time of all transfers over their number) and the blocks dropped (before
or beyond the partition). Run without vision (``user.vision: false``) it is their test.

**Scoring** (:func:`transfer_count`, a pure function of a transfer's outcome): the block
is *carried over* (:func:`carried_over`) when it was in the hand with its bottom above
the partition (:data:`PARTITION_HEIGHT_M`) when the wrist reached the top of the carry,
where the horizontal crossing is taken to happen. A carried block that was let go (the
hand opened) is a block moved; one that fell after it was carried over is
``dropped_beyond`` and counts as a block moved too; one that fell before is a drop; one
crushed a break; one the hand would not let go is not released (an estimate that does
not fall to zero at rest keeps the hand closed); one held but not clear of the partition
is ``not_cleared``; a transfer that had not ended when the time ran out does not count.

**What differs from the published test**: the horizontal carry (about 25 cm over the
partition) is not simulated, the wrist moves vertically only; the block is alone on the
table, not in a box of 150 to pick from; the hand starts each transfer open around the
block; a block that lands beyond the partition but outside the box is not told apart.
The references are the same test driven by the user's own force (no sEMG path) and felt
by touch: estimator ``intact`` (the intact hand: pre-shaped, human speed, grip coupled to
load) and ``ideal_interface`` (the prosthesis's hand; the intact-hand reference before
issue 37).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import replace
from typing import Any

import numpy as np

from estimation.threads import one_blas_thread
from scenarios.runners.feedback_tasks import TaskSetup
from scenarios.schema import Scenario

PARTITION_HEIGHT_M = 0.152
"""The test's partition, m (15.2 cm; Mathiowetz et al. 1985)."""
PARTITION_CLEARANCE_M = 0.16
"""How high the wrist lifts a block to clear the partition, m."""
MAX_TRANSFERS = 60
"""The most transfers one run attempts (one per second would be intact adults' pace)."""
ONSET_MARGIN_S = 1.5
"""Time before the user's contraction begins in a trial's clock (rest, onset jitter), s."""
COUNT_KEYS = ("blocks", "dropped_beyond", "drops", "breaks", "not_lifted", "not_released",
              "not_cleared")
"""What a finished transfer may count as (:func:`transfer_count`); ``blocks`` also counts
the ``dropped_beyond``."""
SCORED = ("blocks", "dropped_beyond")
"""The counts that score a block moved (the published rule)."""


def transfer_count(outcome: str, released: bool, over: bool) -> str:
    """The count a finished transfer adds to, by the published scoring (module notes).

    Parameters
    ----------
    outcome : {"held", "dropped", "crushed", "not_lifted"}
        The trial's outcome (:class:`scenarios.runners.trial_outcome.TrialReferee`).
    released : bool
        The hand let go of the block by the end of the transfer.
    over : bool
        The block was carried over the partition (:func:`carried_over`).

    Returns
    -------
    str
        One of :data:`COUNT_KEYS` except that ``dropped_beyond`` is returned for a
        block that fell after it was carried over (it scores, :data:`SCORED`).
    """
    if outcome == "crushed":
        return "breaks"
    if outcome == "dropped":
        return "dropped_beyond" if over else "drops"
    if outcome != "held":
        return "not_lifted"
    if not over:
        return "not_cleared"
    return "blocks" if released else "not_released"


def carried_over(traces: Mapping[str, np.ndarray], fell_s: float | None, half_height_m: float,
                 top_m: float = PARTITION_CLEARANCE_M) -> bool:
    """Whether the block was carried over the partition in a transfer's traces.

    True when, at a step where the wrist's set-point had reached the top of the carry
    (``top_m``), the block had not yet fallen (before ``fell_s``) and its bottom (its
    centre's height less ``half_height_m``) was above :data:`PARTITION_HEIGHT_M`.

    Parameters
    ----------
    traces : mapping of ndarray, each shape (n_steps,)
        ``t_s``, ``wrist_height_m`` and ``object_height_m`` (m above the table).
    fell_s : float or None
        When the block fell out of the hand, s (None: it did not).
    half_height_m : float
        Half the block's height, m.
    """
    t = np.asarray(traces["t_s"])
    at_top = np.asarray(traces["wrist_height_m"]) >= top_m - 1e-6
    clear = np.asarray(traces["object_height_m"]) - half_height_m >= PARTITION_HEIGHT_M
    in_hand = np.ones(t.size, dtype=bool) if fell_s is None else t < fell_s
    return bool(np.any(at_top & clear & in_hand))


def run_transfers_scenario(scenario: Scenario) -> dict[str, Any]:
    """Runner of kind ``transfers``: blocks moved in ``protocol.duration_s`` (module notes).

    With ``protocol.blocks`` set the test is untimed: that many transfers, each once
    (``duration_s`` then does not apply).

    Returns
    -------
    dict
        The identity fields, ``duration_s``, ``reach_s`` and ``transport_s`` (the arm's
        movement times used), ``transfers`` (started), ``blocks`` (scored: let go over the
        partition, or dropped beyond it), ``dropped_beyond`` (of ``blocks``), ``drops``
        (fell before the partition), ``breaks``, ``not_lifted`` (trials that ran out of
        time before a lift), ``not_released`` (put down, but the hand did not open: the
        block stays in it), ``not_cleared`` (held but not over the partition),
        ``blocks_per_min``, ``transfer_s`` (mean time of a scored block, reach included),
        ``attempts`` (lifts per transfer) and ``user_corrections``, plus timings;
        ``elapsed_s`` (the time of the transfers made), ``time_per_block_s`` (it over
        the transfers made) and ``blocks_dropped`` (``drops`` plus ``dropped_beyond``);
        an untimed test's ``blocks_per_min`` is over ``elapsed_s``.
    """
    p = scenario.protocol
    with one_blas_thread():
        setup = TaskSetup(scenario)
        lift_s = setup.params.lift_s
        reach_s = lift_s if p.reach_s is None else float(p.reach_s)
        transport_s = lift_s if p.transport_s is None else float(p.transport_s)
        carry = replace(setup.grasp_task(hold_s=0.0), lift_height_m=PARTITION_CLEARANCE_M,
                        move_s=0.5 * transport_s)
        seqs = np.random.SeedSequence(int(scenario.seed or 0)).spawn(4)[3].spawn(MAX_TRANSFERS)
        untimed = p.blocks is not None
        if untimed:
            seqs = seqs[:p.blocks]
        elapsed = 0.0
        counts = dict.fromkeys(("transfers", *COUNT_KEYS), 0)
        times: list[float] = []
        attempts = corrections = 0
        for seq in seqs:
            remaining = math.inf if untimed else p.duration_s - elapsed - reach_s
            if remaining <= 0:
                break
            setup.trial_seqs = [seq.spawn(3)]
            limit_s = min(float(setup.operator.default_trial_s), remaining + ONSET_MARGIN_S)
            t = setup.trial(0, replace(carry, limit_s=limit_s))
            took = reach_s + float(t.traces["t_s"][-1]) - t.stream.start_s
            if not untimed and took > p.duration_s - elapsed:  # the time ran out in it
                break
            elapsed += took
            counts["transfers"] += 1
            attempts += t.attempts
            corrections += setup.operator.corrections
            over = carried_over(t.traces, t.referee.fell_s, setup.obj.half_height_m)
            key = transfer_count(t.referee.outcome, t.referee.released, over)
            counts[key] += 1
            if key == "dropped_beyond":  # scores as a block moved too
                counts["blocks"] += 1
            if key in SCORED:
                times.append(took)
    minutes = (elapsed if untimed else float(p.duration_s)) / 60.0
    return {**setup.identity(), "duration_s": float(p.duration_s), "reach_s": reach_s,
            "transport_s": transport_s, **counts,
            "blocks_per_min": counts["blocks"] / minutes if minutes > 0 else None,
            "elapsed_s": elapsed,
            "time_per_block_s": elapsed / counts["transfers"] if counts["transfers"] else None,
            "blocks_dropped": counts["drops"] + counts["dropped_beyond"],
            "transfer_s": float(np.mean(times)) if times else None,
            "attempts": attempts / counts["transfers"] if counts["transfers"] else None,
            "user_corrections": corrections, **setup.timings}
