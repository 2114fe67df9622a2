"""Timed transfers, in the style of the Box and Blocks Test: blocks moved per minute.

The Box and Blocks Test counts the 2.5 cm blocks a person moves over a 15.2 cm
partition in 60 s, one at a time (Mathiowetz et al. 1985); experienced transradial
myoelectric users move 15-21 blocks per minute (CALIBRATION.md, "Practised users").

Kind ``transfers`` (protocol ``timed_transfers``): one practised user grasps a block
(``transfer_block`` by default, a 50 mm cube: this hand cannot carry the test's 25 mm
cubes), lifts it over the partition and puts it down beyond, again and again, until
``protocol.duration_s`` has passed. Each transfer is a trial the user paces
(:mod:`sim.user.reacting`): they close the hand, lift when the grip looks secure, try
again when the block stays behind, carry it over and let go. The carry over the
partition is one arm movement of the user's ``lift_s`` (up in half of it, down in the
other half), and between transfers the arm reaches back for the next block in
``lift_s`` too: natural reach and transport movements take about 0.5-0.8 s (Jeannerod
1984), the same arm for the prosthesis and for the intact hand. Those movement times
come from people, never from the score. The hand, the sEMG and the user's decisions are
simulated; the horizontal carry is not (the wrist moves vertically only).

A transfer counts as a block moved when the block was lifted over the partition, put
down without falling and let go (the hand opened); a block that fell is a drop, one
crushed a break, one the hand would not let go is not released (an estimate that does
not fall to zero at rest keeps the hand closed); a transfer that had not ended when the
time ran out does not count. The intact-hand reference is the
same test with estimator ``intact`` (the user's own force drives the hand, no sEMG path)
and feedback ``touch``.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from estimation.threads import one_blas_thread
from scenarios.runners.feedback_tasks import TaskSetup
from scenarios.schema import Scenario

PARTITION_CLEARANCE_M = 0.16
"""How high a block is lifted to clear the test's 15.2 cm partition, m."""
MAX_TRANSFERS = 60
"""The most transfers one run attempts (one per second would be intact adults' pace)."""
ONSET_MARGIN_S = 1.5
"""Time before the user's contraction begins in a trial's clock (rest, onset jitter), s."""


def run_transfers_scenario(scenario: Scenario) -> dict[str, Any]:
    """Runner of kind ``transfers``: blocks moved in ``protocol.duration_s`` (module notes).

    Returns
    -------
    dict
        The identity fields, ``duration_s``, ``transfers`` (started), ``blocks`` (moved),
        ``drops``, ``breaks``, ``not_lifted`` (trials that ran out of time before a lift),
        ``not_released`` (put down, but the hand did not open: the block stays in it),
        ``blocks_per_min``, ``transfer_s`` (mean time of a moved block, reach included),
        ``attempts`` (lifts per transfer) and ``user_corrections``, plus timings.
    """
    p = scenario.protocol
    with one_blas_thread():
        setup = TaskSetup(scenario)
        reach_s = setup.params.lift_s
        carry = replace(setup.grasp_task(hold_s=0.0), lift_height_m=PARTITION_CLEARANCE_M,
                        move_s=0.5 * reach_s)
        seqs = np.random.SeedSequence(int(scenario.seed or 0)).spawn(4)[3].spawn(MAX_TRANSFERS)
        elapsed = 0.0
        counts = dict.fromkeys(("transfers", "blocks", "drops", "breaks", "not_lifted",
                                "not_released"), 0)
        times: list[float] = []
        attempts = corrections = 0
        for seq in seqs:
            remaining = p.duration_s - elapsed - reach_s
            if remaining <= 0:
                break
            setup.trial_seqs = [seq.spawn(3)]
            limit_s = min(float(setup.operator.default_trial_s), remaining + ONSET_MARGIN_S)
            t = setup.trial(0, replace(carry, limit_s=limit_s))
            took = reach_s + float(t.traces["t_s"][-1]) - t.stream.start_s
            if took > p.duration_s - elapsed:  # the time ran out during this transfer
                break
            elapsed += took
            counts["transfers"] += 1
            attempts += t.attempts
            corrections += setup.operator.corrections
            outcome = t.referee.outcome
            if outcome == "held" and t.referee.released:
                counts["blocks"] += 1
                times.append(took)
            elif outcome == "held":  # put down, but the hand would not let go
                counts["not_released"] += 1
            else:
                counts[{"crushed": "breaks", "dropped": "drops"}.get(outcome, "not_lifted")] += 1
    return {**setup.identity(), "duration_s": float(p.duration_s), **counts,
            "blocks_per_min": 60.0 * counts["blocks"] / p.duration_s,
            "transfer_s": float(np.mean(times)) if times else None,
            "attempts": attempts / counts["transfers"] if counts["transfers"] else None,
            "user_corrections": corrections, **setup.timings}
