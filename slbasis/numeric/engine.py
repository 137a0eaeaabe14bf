"""Which engine evaluates the recurrence (numpy or compiled), and the threaded drivers.

Engines:

``"numpy"``
    :mod:`slbasis.numeric.evaluate`: vectorised numpy over blocks of samples. Always
    there; the reference the compiled engine is tested against.
``"numba"``
    :mod:`slbasis.numeric.compiled`: the same recurrence compiled by numba (the optional
    extra ``fast``), split over threads by contiguous ranges of samples, each thread with
    its own partial sums (reduced at the end in a fixed order). Compiled on first use and
    cached on disk.
``"auto"`` (default)
    ``"numba"`` if numba imports, the environment variables ``SLBASIS_NO_NUMBA`` and
    ``NUMBA_DISABLE_JIT`` are unset (or ``0``), the call is large enough to gain from the
    compiled kernels (:func:`work` of ``N`` functions at ``len(x)`` points ``>= 2^16``
    function values) and its kernels are compiled or cached (:mod:`slbasis.numeric.jit`:
    until then numpy runs while they compile in a background process; from ``2^32``
    values the call compiles them itself); ``"numpy"`` otherwise.

Threads: :func:`slbasis.runtime.compiled_threads` (numba's thread count, from the
``NUMBA_NUM_THREADS`` environment variable or ``numba.set_num_threads``, unless the
library's thread override is set); calls below ``2^20`` function values per thread run on the
calling thread only.

Lanes: a projection deals its samples, block by block and round robin, to a number of
*lanes* that depends on the call's size only (at most :data:`MAX_LANES`); each lane sums
its samples on its own and the lanes' sums are added in lane order.  The threads run
whole lanes, so the result is the same bit for bit whatever the number of threads (one
thread, the default environment's, or an override).
"""

from __future__ import annotations

import functools
import os
from concurrent.futures import ThreadPoolExecutor
from types import ModuleType

import numpy as np

from ..runtime import compiled_threads

__all__ = [
    "ENGINES",
    "NUMPY_ROW_OVERHEAD",
    "numba_available",
    "resolve",
    "work",
    "evaluate_compiled",
    "project_compiled",
    "MAX_LANES",
]

ENGINES = ("auto", "numpy", "numba")
_AUTO_MIN_WORK = 1 << 16  # function values: below this "auto" stays with numpy
#: the fixed cost of one row of the numpy engine (a handful of numpy calls on the block
#: of samples), in function values: measured 5.2 us per row at 2 samples against 5 ns
#: per function value at 2 * 10^4 samples (N = 400), i.e. ~1000 values
NUMPY_ROW_OVERHEAD = 1 << 10
_THREAD_MIN_WORK = 1 << 20  # function values per thread worth a thread
#: function values from which "auto" compiles the kernels on the call when they are not
#: compiled yet (:mod:`.jit`): the numpy engine's ~5 ns per value then takes about as long
#: as compiling them (~20 s on one core)
_COMPILE_NOW_WORK = 1 << 32
#: environment variables that switch the compiled engine off
_SWITCHES = ("SLBASIS_NO_NUMBA", "NUMBA_DISABLE_JIT")
#: lanes of a projection at most (module docstring): enough to keep eight threads busy;
#: each lane keeps an ``N x k`` array of sums
MAX_LANES = 8


@functools.lru_cache(maxsize=1)
def _compiled() -> ModuleType | None:
    """The compiled-kernel module, or ``None`` when numba is not installed."""
    try:
        from . import compiled
    except ImportError:
        return None
    return compiled


def _disabled() -> bool:
    """``SLBASIS_NO_NUMBA`` set, or numba's own ``NUMBA_DISABLE_JIT`` (under which the
    kernels would run as plain Python loops, orders of magnitude slower than numpy)."""
    return any(os.environ.get(v, "") not in ("", "0") for v in _SWITCHES)


def numba_available() -> bool:
    """Whether the compiled engine can be used.

    Returns
    -------
    bool
        True when numba is installed and neither ``SLBASIS_NO_NUMBA`` nor
        ``NUMBA_DISABLE_JIT`` is set (under the latter the kernels would run as plain Python
        loops, slower than numpy).
    """
    return not _disabled() and _compiled() is not None


def resolve(engine: str, work: int) -> str:
    """The engine (``"numpy"`` or ``"numba"``) that runs a call of ``work`` function values.

    ``"auto"`` takes the compiled engine when numba is available, the call is large enough
    to gain from it (``work >= 2^16``) and its kernels are compiled or cached (or the call is
    so large that compiling on the call costs less than numpy would).

    Parameters
    ----------
    engine : {"auto", "numpy", "numba"}
        The engine asked for.
    work : int
        The call's cost in function values (:func:`work`).

    Returns
    -------
    str
        ``"numpy"`` or ``"numba"``.

    Raises
    ------
    ValueError
        If ``engine`` is unknown.
    RuntimeError
        If ``"numba"`` is asked for and numba is disabled or not installed.

    Examples
    --------
    >>> resolve("auto", 100), resolve("numpy", 10**9)
    ('numpy', 'numpy')
    """
    if engine not in ENGINES:
        raise ValueError(f"engine: expected one of {ENGINES}, got {engine!r}")
    if engine == "numpy":
        return "numpy"
    if engine == "numba":
        if _disabled():
            raise RuntimeError(
                "engine='numba': disabled by the environment (SLBASIS_NO_NUMBA or "
                "NUMBA_DISABLE_JIT)"
            )
        if _compiled() is None:
            raise RuntimeError(
                "engine='numba': numba is not installed (pip install 'slbasis-hdpbsid[fast]')"
            )
        return "numba"
    if work < _AUTO_MIN_WORK or not numba_available():
        return "numpy"
    from . import jit  # here: ``python -m slbasis.numeric.jit`` must find it not imported

    return "numba" if work >= _COMPILE_NOW_WORK or jit.ready(_compiled()) else "numpy"


def work(N: int, n_samples: int) -> int:
    """The cost of evaluating ``N`` functions at ``n_samples`` points with the numpy engine.

    The numpy engine loops over the ``N`` rows in Python, so a call with few samples still
    costs :data:`NUMPY_ROW_OVERHEAD` per row; counting only ``N n_samples`` would keep such
    calls on the slow engine.

    Parameters
    ----------
    N : int
        Number of functions.
    n_samples : int
        Number of points.

    Returns
    -------
    int
        ``N (n_samples + NUMPY_ROW_OVERHEAD)`` function values.

    Examples
    --------
    >>> work(10, 100)
    11240
    """
    return int(N) * (int(n_samples) + NUMPY_ROW_OVERHEAD)


def _threads() -> int:
    return compiled_threads()


def _ranges(n_samples: int, work_per_sample: int) -> list[tuple[int, int]]:
    """Contiguous sample ranges, one per thread, whole blocks each (the last takes the rest)."""
    block = _compiled().BLOCK
    by_work = (n_samples * work_per_sample) // _THREAD_MIN_WORK
    parts = max(1, min(_threads(), by_work, -(-n_samples // block)))
    per = -(-n_samples // (parts * block)) * block
    return [(s, min(s + per, n_samples)) for s in range(0, n_samples, per)]


def _interleaved(n_samples: int, parts: int) -> np.ndarray:
    """A permutation of the samples that lists the blocks of ``BLOCK`` samples group by
    group, group ``i`` holding every ``parts``-th block from block ``i`` (round robin):
    each group then takes blocks from all along the record, so that a cost that varies
    along the record is shared about evenly between the groups."""
    block = _compiled().BLOCK
    starts = np.arange(0, n_samples, block)
    groups = [starts[i::parts] for i in range(parts)]
    return np.concatenate([np.arange(s, min(s + block, n_samples)) for g in groups for s in g])


def _lanes(n_samples: int, work_per_sample: int) -> tuple[np.ndarray | None, list[tuple[int, int]]]:
    """The lanes of a projection (module docstring): ``(permutation, ranges)``, lane ``g``
    the range ``g`` of the permuted samples, i.e. the blocks ``g, g + L, g + 2 L, ...``
    (:func:`_interleaved`); no permutation for one lane.

    ``L`` depends on the call's size only: the largest power of two not above
    :data:`MAX_LANES`, the number of blocks, or the function values in units of ``2^20``
    (a lane's work worth a thread).  A power of two divides the usual thread counts (2, 4,
    8), so whole lanes share out evenly between them."""
    block = _compiled().BLOCK
    n_blocks = -(-n_samples // block)
    most = max(1, min(MAX_LANES, (n_samples * work_per_sample) // _THREAD_MIN_WORK, n_blocks))
    lanes = 1 << (most.bit_length() - 1)
    if lanes == 1:
        return None, [(0, n_samples)]
    sizes = [
        sum(min(block, n_samples - s) for s in range(g * block, n_samples, lanes * block))
        for g in range(lanes)
    ]
    bounds = np.cumsum([0, *sizes])
    return _interleaved(n_samples, lanes), [
        (int(bounds[g]), int(bounds[g + 1])) for g in range(lanes)
    ]


def _run(tasks, threads: int | None = None) -> list:
    """Run the thunks ``tasks`` on ``threads`` threads (default: one per task, the first
    on this thread); fewer threads than tasks take the next task as they finish (this
    thread waits).  The results in the order of ``tasks``."""
    threads = len(tasks) if threads is None else max(1, min(threads, len(tasks)))
    if threads == 1:
        return [task() for task in tasks]
    if threads == len(tasks):
        with ThreadPoolExecutor(max_workers=threads - 1) as pool:
            futures = [pool.submit(task) for task in tasks[1:]]
            return [tasks[0]()] + [f.result() for f in futures]
    with ThreadPoolExecutor(max_workers=threads) as pool:  # each takes the next task
        return list(pool.map(lambda task: task(), tasks))


def _coefficients(rec) -> tuple:
    return (
        np.ascontiguousarray(rec.b),
        np.ascontiguousarray(rec.A_prev),
        np.ascontiguousarray(rec.A_next),
    )


def evaluate_compiled(
    rec, x: np.ndarray, m0: np.ndarray, e0: np.ndarray, renorm: np.ndarray, out: np.ndarray
) -> None:
    """Fill the C-contiguous ``out`` with ``phi_n(x_i)`` (compiled, threaded by sample ranges).

    Parameters
    ----------
    rec : Recurrence
        The recurrence coefficients (:func:`slbasis.numeric.evaluate.recurrence`).
    x : ndarray, shape (k,)
        Points.
    m0 : ndarray, shape (k,)
        Mantissas of ``phi_0(x)``.
    e0 : ndarray, shape (k,)
        Base-2 exponents of ``phi_0(x)``.
    renorm : ndarray of bool, shape (N,)
        Rows before which the mantissa pair is renormalised.
    out : ndarray, shape (N, k)
        C-contiguous output, filled in place.
    """
    kernels = _compiled()
    b, a_prev, a_next = _coefficients(rec)
    N = out.shape[0]

    def task(lo: int, hi: int):
        return lambda: kernels.eval_range(
            x[lo:hi], m0[lo:hi], e0[lo:hi], b, a_prev, a_next, renorm, out, lo
        )

    _run([task(lo, hi) for lo, hi in _ranges(x.size, N)])


def project_compiled(
    rec,
    N: int,
    x: np.ndarray,
    m0: np.ndarray,
    e0: np.ndarray,
    wy: np.ndarray,
    renorm: np.ndarray,
    columns: int | None = None,
) -> tuple[np.ndarray, int]:
    """The fused projection ``c[n, j] = sum_i phi_n(x_i) wy[j, i]`` (compiled, threaded).

    The samples are dealt block by block to lanes whose number depends on the call's size
    only (each lane every ``lanes``-th block: the cost of a sample varies along the record,
    far samples of a Gaussian weight taking the slow paths of the exponent handling); each
    lane sums on its own and the lanes are added in order, so the sums are the same bit
    for bit on any number of threads (module docstring).

    Parameters
    ----------
    rec : Recurrence
        The recurrence coefficients.
    N : int
        Number of functions.
    x : ndarray, shape (Ns,)
        Points.
    m0 : ndarray, shape (Ns,)
        Mantissas of ``phi_0(x)``.
    e0 : ndarray, shape (Ns,)
        Base-2 exponents of ``phi_0(x)``.
    wy : ndarray, shape (k, Ns)
        Weighted signals.
    renorm : ndarray of bool, shape (N,)
        Rows before which the mantissa pair is renormalised.
    columns : int, optional
        ``k`` (all rows sum all signals) or ``k / 2`` (even rows the first half, odd rows
        the second, :func:`slbasis.numeric.compiled.project_range`).

    Returns
    -------
    c : ndarray, shape (N, columns)
        The sums.
    bad : int
        The samples where ``phi_{N-1}`` is not finite.

    Raises
    ------
    ValueError
        If ``columns`` is neither ``k`` nor half of it.
    """
    kernels = _compiled()
    b, a_prev, a_next = _coefficients(rec)
    wy = np.ascontiguousarray(wy)
    k = wy.shape[0] if columns is None else int(columns)
    if k < 1 or wy.shape[0] % k or wy.shape[0] // k > 2:
        raise ValueError(f"columns: expected {wy.shape[0]} or half of it, got {columns}")

    # the lanes depend on the call's size only, not on the threads (module docstring); the
    # cost of a sample is not uniform along the record (samples far out on a basis with a
    # Gaussian weight start with phi_0 far below 2^-1022 and take the slow paths of the
    # exponent handling: the outer half of a Hermite record was measured 1.3x the cost of
    # the inner half), so each lane takes every L-th block and the lanes cost about the same
    order, ranges = _lanes(x.size, N)
    if order is not None:
        x, m0, e0, wy = x[order], m0[order], e0[order], np.ascontiguousarray(wy[:, order])

    def task(lo: int, hi: int):
        def run():
            c = np.zeros((N, k))
            bad = kernels.project_range(
                x[lo:hi], m0[lo:hi], e0[lo:hi], wy[:, lo:hi], b, a_prev, a_next, renorm, c
            )
            return c, bad

        return run

    parts = _run([task(lo, hi) for lo, hi in ranges], _threads())
    c = parts[0][0]
    for part, _ in parts[1:]:
        c += part
    return c, sum(bad for _, bad in parts)
