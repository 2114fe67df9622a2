"""Running many scenarios: sweeps on forked local workers or a Dask scheduler, and signals.

May import: :mod:`scenarios.schema`, :mod:`scenarios.store`, :mod:`scenarios.runners`
(by name, through the runner registry).
"""
