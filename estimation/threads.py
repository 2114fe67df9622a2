"""One BLAS thread for code whose matrices are tiny.

Identification, filtering and the closed loop multiply matrices of a few rows:
BLAS worker threads only add start-up overhead there (and noise in timings),
and a sweep already runs one scenario per core.
"""

from __future__ import annotations

from threadpoolctl import threadpool_limits


def one_blas_thread() -> threadpool_limits:
    """Context manager that limits BLAS to one thread inside its ``with`` block.

    Returns
    -------
    threadpoolctl.threadpool_limits
        Restores the previous thread counts on exit.
    """
    return threadpool_limits(limits=1, user_api="blas")
