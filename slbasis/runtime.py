"""The thread counts of the library's work: BLAS/LAPACK and the compiled kernels.

Policy (the library decides; the caller can override, see below):

* **small-matrix work** -- everything inside a library call (:func:`library_call`: the
  identification entry points, the refinement, the selection sweeps, the simulations):
  **one BLAS thread**.  The refinement and the sweeps make thousands of LAPACK calls
  on matrices of tens to hundreds of rows; a threaded BLAS wakes and synchronises its
  threads on every call, which costs more than the call (measured on 2 cores:
  ``identify`` on a 6000-sample record 4-6x slower in wall time and 8-12x in CPU time
  than with one thread, and worse when the cores are busy).
* **large work** -- a single factorisation or product of at least :data:`LARGE_FLOPS`
  floating-point operations inside a call (:func:`large_work`: the QR of a long record's
  regressors): the BLAS threads the caller had when the call began (by default the
  number of cores), where the synchronisation is a negligible part of the call.
* **compiled kernels** (the projection of long records, :mod:`slbasis.numeric.engine`):
  :func:`compiled_threads`, numba's thread count (``NUMBA_NUM_THREADS`` or
  ``numba.set_num_threads``); the engine still runs a call below its per-thread work
  threshold on the calling thread only.

Override: the environment variable :data:`ENV_VAR` (``HDPBSID_NUM_THREADS=4``) or the
context manager :func:`num_threads` (``with num_threads(4): ...``, which wins over the
variable) sets one count for every kind of work (BLAS and compiled kernels); ``1`` makes
every call single-threaded.  A caller's own limit is respected: the library never raises
the BLAS threads above the count in force when its call began (a
``threadpoolctl.threadpool_limits(1)`` around a call, or ``OPENBLAS_NUM_THREADS=1``,
keeps even the large work on one thread), except when the override asks for more.

The limits are set with :mod:`threadpoolctl` (any BLAS it knows: OpenBLAS, MKL, BLIS,
...) once, around the outermost library call, and restored when it returns; calls made
inside it change nothing.

Warnings name the user's line: :func:`user_stacklevel` is the ``stacklevel`` that
attributes a warning to the first caller outside ``slbasis`` and ``hdpbsid``, however
deep inside the library it was raised.
"""

from __future__ import annotations

import contextlib
import contextvars
import functools
import os
import sys
import threading
from collections.abc import Callable, Iterator
from typing import Any, TypeVar

__all__ = [
    "ENV_VAR",
    "LARGE_FLOPS",
    "blas_threads",
    "compiled_threads",
    "large_work",
    "library_call",
    "num_threads",
    "requested_threads",
    "user_stacklevel",
]

#: The environment variable of the override: a positive integer, the thread count of every
#: kind of work (BLAS and compiled kernels) inside the library's calls.
ENV_VAR = "HDPBSID_NUM_THREADS"

#: Floating-point operations from which one BLAS/LAPACK call gets the caller's threads:
#: ``2^30`` (about 0.1 s on one core at 10 GFlop/s).  A threaded factorisation
#: synchronises its threads once per panel (``k / 32`` panels for ``k`` columns, tens of
#: microseconds each), which is below one percent of such a call and can save up to half
#: of it on two cores; below about ``2^26`` operations the synchronisation is comparable
#: to the work, and the refinement's and sweeps' calls are far below that.
LARGE_FLOPS = float(2**30)

#: Directories of the library's packages (installed side by side in one distribution):
#: frames in them are skipped by :func:`user_stacklevel`.
_LIBRARY_DIRS = tuple(
    os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), name) + os.sep
    for name in ("slbasis", "hdpbsid")
)

F = TypeVar("F", bound=Callable[..., Any])

_override: contextvars.ContextVar[int | None] = contextvars.ContextVar(
    "slbasis_num_threads", default=None
)
_lock = threading.RLock()
_state: dict[str, Any] = {
    "depth": 0,  # library calls in progress (all threads)
    "outer": None,  # BLAS threads in force when the outermost call began
    "limiter": None,  # the threadpoolctl limiter of the outermost call
    "controller": None,  # threadpoolctl's controller of the loaded BLAS libraries
    "modules": -1,  # len(sys.modules) when the controller was made
}


def _check_count(n: Any, name: str) -> int:
    if isinstance(n, bool) or not isinstance(n, int) or n < 1:
        raise ValueError(f"{name}: expected a positive integer number of threads, got {n!r}")
    return int(n)


def _from_environment() -> int | None:
    value = os.environ.get(ENV_VAR, "").strip()
    if not value:
        return None
    try:
        return _check_count(int(value), ENV_VAR)
    except ValueError:
        raise ValueError(
            f"environment variable {ENV_VAR}: expected a positive integer number of "
            f"threads, got {value!r}"
        ) from None


def requested_threads() -> int | None:
    """The caller's thread count for every kind of work, or ``None`` (the library decides).

    :func:`num_threads` wins over the environment variable :data:`ENV_VAR`.

    Returns
    -------
    int or None
        The count asked for, or None when neither is set.

    Raises
    ------
    ValueError
        When :data:`ENV_VAR` is set to anything but a positive integer.
    """
    n = _override.get()
    return n if n is not None else _from_environment()


@contextlib.contextmanager
def num_threads(n: int | None) -> Iterator[None]:
    """Run the library's calls inside the block with ``n`` threads for every kind of work.

    Parameters
    ----------
    n : int or None
        BLAS threads and compiled-kernel threads of the calls made inside the block;
        ``None`` restores the library's own choice (:mod:`slbasis.runtime`) inside it.

    Yields
    ------
    None
        The block runs with the count in force (restored on leaving it).

    Raises
    ------
    ValueError
        When ``n`` is not a positive integer or ``None``.

    Examples
    --------
    >>> from slbasis.runtime import num_threads, requested_threads
    >>> with num_threads(2):
    ...     requested_threads()
    2
    """
    if n is not None:
        n = _check_count(n, "n")
    token = _override.set(n)
    try:
        yield
    finally:
        _override.reset(token)


def _controller() -> Any:
    """threadpoolctl's controller of the BLAS libraries loaded now (rebuilt when modules
    were imported since, which may have loaded another BLAS), or ``None`` without
    threadpoolctl."""
    if _state["modules"] != len(sys.modules):
        try:
            from threadpoolctl import ThreadpoolController
        except ImportError:  # pragma: no cover - threadpoolctl is a dependency
            return None
        _state["controller"] = ThreadpoolController().select(user_api="blas")
        _state["modules"] = len(sys.modules)
    return _state["controller"]


def blas_threads() -> int | None:
    """The BLAS thread count in force now (the largest over the loaded BLAS libraries),
    ``None`` when threadpoolctl finds no BLAS.

    Returns
    -------
    int or None
        The thread count.

    Examples
    --------
    >>> import numpy
    >>> from slbasis.runtime import blas_threads
    >>> blas_threads() >= 1
    True
    """
    ctl = _controller()
    if ctl is None or not ctl.lib_controllers:
        return None
    return max(int(lib.num_threads) for lib in ctl.lib_controllers)


def _set_blas(n: int) -> Any:
    ctl = _controller()
    if ctl is None or not ctl.lib_controllers:
        return None
    return ctl.limit(limits=n)


def _enter() -> None:
    with _lock:
        _state["depth"] += 1
        if _state["depth"] > 1:
            return
        want = requested_threads()
        _state["outer"] = blas_threads()
        _state["limiter"] = _set_blas(1 if want is None else want)


def _exit() -> None:
    with _lock:
        _state["depth"] -= 1
        if _state["depth"] > 0:
            return
        if _state["limiter"] is not None:
            _state["limiter"].restore_original_limits()
            _state["limiter"] = None
        # the modules the call imported (its first use of scipy.optimize, numba, ...) are
        # scanned now, not at the start of the next call: the scan resolves the path of
        # every newly loaded shared library, a one-off cost of the process that belongs
        # with the imports of the call that caused it
        _controller()


def library_call(func: F) -> F:
    """Decorate a public entry point: BLAS limited as :mod:`slbasis.runtime` describes
    while the outermost decorated call runs, restored after (also on an exception).

    Parameters
    ----------
    func : callable
        The entry point.

    Returns
    -------
    callable
        ``func`` run inside the limits (same signature, same result).

    Examples
    --------
    >>> import numpy as np
    >>> from slbasis.runtime import blas_threads, library_call
    >>> @library_call
    ... def inside():
    ...     return blas_threads()
    >>> inside()
    1
    """

    @functools.wraps(func)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        _enter()
        try:
            return func(*args, **kwargs)
        finally:
            _exit()

    return wrapper  # type: ignore[return-value]


@contextlib.contextmanager
def large_work(flops: float) -> Iterator[None]:
    """Give one BLAS/LAPACK call of ``flops`` operations the caller's BLAS threads.

    Inside a library call (:func:`library_call`), without an override, and when
    ``flops >= LARGE_FLOPS``: the BLAS thread count in force when the outermost call
    began, for the duration of the block; anything else is left as it is (the small-work
    limit, the override, or no limit outside the library's calls).

    Parameters
    ----------
    flops : float
        Floating-point operations of the work in the block (e.g. ``2 n k^2`` for the QR
        of an ``n x k`` matrix).

    Yields
    ------
    None
        The block runs with the caller's BLAS threads when the work is large.

    Examples
    --------
    >>> rows, cols = 10**6, 64
    >>> with large_work(2.0 * rows * cols**2):
    ...     pass
    """
    outer = _state["outer"]
    if (
        flops < LARGE_FLOPS
        or _state["depth"] == 0
        or outer is None
        or outer <= 1
        or requested_threads() is not None
    ):
        yield
        return
    limiter = _set_blas(outer)
    try:
        yield
    finally:
        if limiter is not None:
            limiter.restore_original_limits()


def compiled_threads() -> int:
    """Threads of the compiled kernels: the override (:func:`requested_threads`) if any,
    else numba's thread count (``NUMBA_NUM_THREADS``, ``numba.set_num_threads``).

    Returns
    -------
    int
        The thread count, ``>= 1``.

    Examples
    --------
    >>> from slbasis.runtime import compiled_threads, num_threads
    >>> with num_threads(3):
    ...     compiled_threads()
    3
    """
    want = requested_threads()
    if want is not None:
        return want
    import numba

    return max(1, int(numba.get_num_threads()))


def user_stacklevel() -> int:
    """The ``stacklevel`` for :func:`warnings.warn` that names the user's code.

    Counted from the function calling :func:`warnings.warn` (level 1) outwards to the
    first frame whose file lies outside the ``slbasis`` and ``hdpbsid`` packages, so a
    warning raised deep in the library points at the line of the user's call, whatever
    the depth of the internal call chain (a fixed ``stacklevel`` is right for one chain
    only).  When every frame is the library's (a worker thread or process), the
    outermost library frame.

    Returns
    -------
    int
        The stacklevel to pass, at least 1.

    Examples
    --------
    Called from code outside the library, the caller itself is the user's frame:

    >>> from slbasis.runtime import user_stacklevel
    >>> user_stacklevel()
    1
    """
    frame = sys._getframe(1)
    level = 1
    while frame.f_back is not None and frame.f_code.co_filename.startswith(_LIBRARY_DIRS):
        frame = frame.f_back
        level += 1
    return level
