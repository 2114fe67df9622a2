"""Running many scenarios: sweep execution (in process, forked children, Dask) and signal handling.

May import: :mod:`scenarios.schema`, :mod:`scenarios.store`, :mod:`scenarios.runners`
(by name, through the runner registry).
"""
