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
"""
