"""Population variants: the calibrated default and the wide one that judges out of population."""

from __future__ import annotations

import numpy as np
import pytest

from sim.user.populations import (
    WIDE,
    UnknownPopulationError,
    population_description,
    population_names,
)
from sim.user.subjects import make_population


def test_variants_keep_the_default_draws_and_change_only_their_own():
    default = make_population(6, 3)
    for variant in ("default", "wide"):
        subjects = make_population(6, 3, variant=variant)
        for a, b in zip(default, subjects, strict=True):
            # anatomy, size, MVC and the FSR device are the default subject's
            assert (a.mvc_n, a.fsr, a.muscles.anatomy_seed) == (b.mvc_n, b.fsr,
                                                                 b.muscles.anatomy_seed)
            assert a.muscles.emd_s == b.muscles.emd_s
    assert make_population(6, 3, variant="wide") == make_population(6, 3, variant="wide")


def test_wide_draws_placement_co_contraction_and_rounds_from_wider_ranges():
    default = make_population(40, 1)
    subjects = make_population(40, 1, variant="wide")
    shift = np.array([s.armband.electrode_shift for s in subjects])
    assert WIDE["electrode_shift"][0] <= shift.min() and shift.max() <= WIDE["electrode_shift"][1]
    assert shift.max() - shift.min() > 2.0  # the band anywhere within +/- 1.5 spacings
    power = np.array([s.muscles.cocontraction_power for s in subjects])
    assert power.max() > 3.0 >= max(s.muscles.cocontraction_power for s in default)
    assert {s.protocol_rounds for s in subjects} == {2, 3}
    # the rig, the FSR and the electrodes' noise keep the default subject's
    for a, b in zip(default, subjects, strict=True):
        assert (a.rig_lag_s, a.contact_std, a.armband.noise_drift_std) == (
            b.rig_lag_s, b.contact_std, b.armband.noise_drift_std)
    rec = subjects[0].paper_session()
    assert len(rec.metadata["profile"]["levels"]) == 3 * subjects[0].protocol_rounds


def test_unknown_variant_and_bad_size_are_named():
    assert {"default", "wide"} <= set(population_names())
    assert "wider" in population_description("wide")
    with pytest.raises(UnknownPopulationError, match="wide"):
        make_population(3, 0, variant="no-such")
    with pytest.raises(ValueError, match="at least 1"):
        make_population(0, 0, variant="wide")
