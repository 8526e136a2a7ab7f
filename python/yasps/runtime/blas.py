"""NumPy's and SciPy's BLAS on one thread while yasps steps.

OpenBLAS's threads busy-wait a while after every call they share. When
yasps' own thread pool takes every core, that spin takes a core from the
pool's PCG team, whose members meet at barriers several times per
iteration, and each barrier then waits for a thread the spin descheduled.
On the STARK bench's bunny on a pinned cloth at 4,270 vertices (two
threads, ``OPENBLAS_NUM_THREADS=2``, what a two-thread run of the bench
sets) a frame took 0.67 s against 0.31 s with one BLAS thread, 40% of the
samples in OpenBLAS's thread server. Stepping's own BLAS calls are small
(dot products, 3x3 algebra), so nothing is lost by running them on one
thread. ``threadpoolctl`` does the limiting; without it (yasps itself needs
only NumPy) nothing is limited.
"""

from __future__ import annotations

from contextlib import AbstractContextManager, nullcontext
from typing import Any, Optional

_controller: Optional[Any] = None


def one_blas_thread() -> AbstractContextManager:
    """A context in which the BLAS libraries loaded in this process (those
    loaded by the first call) use one thread, restored on exit; a no-op
    without threadpoolctl."""
    global _controller
    try:
        from threadpoolctl import ThreadpoolController
    except ImportError:
        return nullcontext()
    if _controller is None:
        # Finding the libraries reads the process's maps: once.
        _controller = ThreadpoolController()
    return _controller.limit(limits=1, user_api="blas")
