"""BLAS thread pinning.

On the 2-core production boxes several workers share the cores; letting OpenBLAS/MKL start a
thread per core in each of them made one eigen-solve 8 times slower (oversubscription).
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

from threadpoolctl import threadpool_limits

__all__ = ["pin_blas_threads"]


@contextmanager
def pin_blas_threads(limit: int = 1) -> Iterator[None]:
    """Limit BLAS (and OpenMP) thread pools to ``limit`` threads inside the block.

    Parameters
    ----------
    limit : int
        Threads per pool while the block runs; the previous limits come back afterwards.
    """
    with threadpool_limits(limits=int(limit)):
        yield
