"""Corpora of virtual subjects for pretrained estimators (:mod:`estimation.transfer`).

:func:`virtual_corpus` is the pretraining corpus ``"virtual"``, registered in
:mod:`estimation.corpora` when the :mod:`scenarios` package is imported.

The ``"virtual"`` corpus records the paper's calibration session (one to three rounds of
three squeezes, by the rig) from ``n_subjects`` subjects of
``make_population(n_subjects, seed, variant=population)`` with the noise generator,
extracts the same features as the person's (all 8 channels or the paper's 6-8, from the
number of inputs), and normalizes each subject as every estimator is normalized: min-max
on the subject's own identification half (the first 50 % of its windows).
"""

from __future__ import annotations

import numpy as np

from estimation.errors import EstimationInputError
from estimation.evaluation import split_index
from estimation.features import FEATURES, PAPER_CHANNELS, extract_features
from estimation.normalize import MinMaxScaling
from sim.user.intent import paper_protocol
from sim.user.subjects import make_population

#: Rounds of the protocol in the corpus' sessions, drawn per subject: people and labs do
#: not all record two rounds, and a one-round session puts its strongest squeeze in the
#: validation half, so the networks also learn to extrapolate above the calibration range.
ROUNDS = (1, 2, 3)

#: Feature layouts a corpus can make: number of inputs -> channels (None: all 8).
LAYOUTS: dict[int, tuple[int, ...] | None] = {
    8 * len(FEATURES): None,
    len(PAPER_CHANNELS) * len(FEATURES): PAPER_CHANNELS,
}


def channels_for(n_inputs: int) -> tuple[int, ...] | None:
    """The channel set whose MAV, RMS and WL give ``n_inputs`` features.

    Raises
    ------
    EstimationInputError
        Another count: only all 8 channels (24 inputs) and the paper's 6-8 (9) are made.
    """
    if n_inputs not in LAYOUTS:
        raise EstimationInputError(
            f"pretrained estimators expect the MAV, RMS and WL of all 8 channels (24 inputs) "
            f"or of the paper's channels 6-8 (9 inputs); found {n_inputs} inputs")
    return LAYOUTS[n_inputs]


def virtual_corpus(*, n_inputs: int, n_subjects: int, seed: int, population: str = "default",
                   generator: str = "noise") -> list[tuple[np.ndarray, np.ndarray, int]]:
    """Normalized features and force of ``n_subjects`` virtual calibration sessions.

    Parameters
    ----------
    n_inputs : int
        24 (all 8 channels) or 9 (channels 6-8).
    n_subjects : int
        Population size.
    seed : int
        Population seed (sessions are seeded from it too).
    population : str
        Population variant (:mod:`sim.user.populations`).
    generator : str
        sEMG generator.

    Returns
    -------
    list of (U, y, n_id)
        Per subject: features (n_windows, n_inputs) and force (n_windows,) scaled 0..1 on
        the identification half, and the number of identification windows.
    """
    channels = channels_for(n_inputs)
    children = np.random.SeedSequence([seed, 0xC0FFEE]).spawn(n_subjects)
    out = []
    subjects = make_population(n_subjects, seed, variant=population)
    for subject, child in zip(subjects, children, strict=True):
        g = np.random.default_rng(child)
        rounds = int(g.choice(ROUNDS))
        rec = subject.record(paper_protocol(g, rounds=rounds), generator=generator, rng=g,
                             rig=True)
        fs = extract_features(rec, channels=channels)
        n_id = split_index(fs.n_windows)
        scaling = MinMaxScaling.fit(fs.X[:n_id], fs.y[:n_id])
        out.append((scaling.transform_u(fs.X), scaling.transform_y(fs.y), n_id))
    return out
