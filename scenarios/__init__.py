"""Experiments: scenario schema, runners, sweeps, results store, reports, CLI.

:mod:`scenarios.schema` validates scenarios and sweep files (names checked
against the registries of the other packages), :mod:`scenarios.runners` runs one
scenario by its kind (the scenario-kind registry is
:mod:`scenarios.runners.dispatch`), :mod:`scenarios.execution` runs sweeps
(on worker processes forked from the driver, or on a Dask scheduler),
:mod:`scenarios.store` keeps results in SQLite,
:mod:`scenarios.report` writes the HTML report (sections registered in
:mod:`scenarios.report.sections`) and :mod:`scenarios.cli` is ``griploop``.

May import: :mod:`sim`, :mod:`estimation`, :mod:`controllers` and any third-party
library of the project. Nothing imports :mod:`scenarios`.

Importing it registers the ``"virtual"`` pretraining corpus of :mod:`estimation.corpora`
(:func:`scenarios.runners.pretraining.virtual_corpus`, by reference: imported when a
network is first pretrained on it; its networks are keyed by the source of the virtual
subjects, :mod:`sim.user`), so every command finds it and estimation names no module of
this layer.
"""

from estimation.corpora import register_corpus as _register_corpus

_register_corpus("virtual", "scenarios.runners.pretraining:virtual_corpus",
                 packages=("sim.user",))
