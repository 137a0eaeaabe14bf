"""Content-keyed memoisation of the expensive, order-independent steps of the methods.

Choosing an order (or a method) identifies the same record several times with different
orders.  The projection of the record onto the basis and the basis-domain operators do
not depend on the order, so they are computed once: :func:`memoize` caches a function's
result under a key made of the *contents* of its array arguments (a SHA-256 digest of
their bytes, shapes and dtypes) and the ``repr`` of every other argument, keeping the
most recent :data:`CACHE_SIZE` results per function.  Arrays are never compared by
identity (a caller may reuse a buffer), and the cached arrays are made read-only, so a
caller that tried to modify a shared result would get an error instead of corrupting
the cache.  An object that defines ``cache_key()`` (a lag operator) is keyed by what that
returns, the arrays and exact numbers that define it; ``None`` there means "cannot be
keyed", and the call is then computed without the cache.

The PBSID core's order-independent stages are memoised here as well
(:func:`past_window_aic`, :func:`varx_stage`): the VARX regression and the singular value
decomposition of ``Gamma_f L_p Z_p`` depend on the data, the lag operator, ``p`` and
``f``, not on the order, which only truncates the decomposition.  An order sweep of one
method (``method="auto"``, :func:`hdpbsid.selection.auto.select_order`) therefore runs them
once per distinct ``(lag, p)``, and every order gets the numbers it would get alone.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
from collections import OrderedDict
from collections.abc import Callable
from typing import Any, TypeVar

import numpy as np

from hdpbsid.core.blocks import BlockPseudo, VarxStage, select_past_window_blocks, varx_stage_blocks
from hdpbsid.core.varx import LagOperator

__all__ = [
    "memoize",
    "clear_caches",
    "digest",
    "CacheSettings",
    "CACHES",
    "CACHE_SIZE",
    "STAGE_CACHE_SIZE",
    "past_window_aic",
    "varx_stage",
]


@dataclasses.dataclass(frozen=True)
class CacheSettings:
    """How many results the memoised functions keep.

    Parameters
    ----------
    size : int, optional
        Results kept per memoised function.
    stage_size : int, optional
        Results kept of the core's stages.

    Examples
    --------
    >>> CacheSettings().stage_size
    32
    """

    #: results kept per memoised function: one order/method selection touches two records
    #: (the estimation part and the whole record) with up to two input holds
    size: int = 8
    #: results kept of the core's stages: a sweep fits, per order, every method with both
    #: input holds, HD-PBSID at up to three operator scales plus its two held-out fits, so
    #: about 16 stages are made per order; twice that keeps the previous order's
    stage_size: int = 32


#: the cache sizes in use
CACHES = CacheSettings()
#: the fields of :data:`CACHES` under their former names
CACHE_SIZE = CACHES.size
STAGE_CACHE_SIZE = CACHES.stage_size


class _Uncacheable(Exception):
    """An argument has no exact key (its ``cache_key()`` returned None)."""


F = TypeVar("F", bound=Callable[..., Any])


def _kernel_key(kernel: Any) -> Any:
    """A catalogue kernel in closed form is fixed by its module and parameters, so two
    bases built from the same family share cache entries; any other kernel (a numerically
    solved one) is keyed by its identity."""
    module, params = getattr(kernel, "module", None), getattr(kernel, "params", None)
    if module is not None and isinstance(params, dict):
        return (type(kernel).__qualname__, getattr(module, "__name__", repr(module)), repr(params))
    return id(kernel)


def _key_part(x: Any, h: Any) -> None:
    if callable(getattr(x, "cache_key", None)):
        k = x.cache_key()
        if k is None:
            raise _Uncacheable
        h.update(type(x).__qualname__.encode())
        _key_part(k, h)
    elif isinstance(x, np.ndarray):
        a = np.ascontiguousarray(x)
        h.update(repr((a.shape, a.dtype.str)).encode())
        if a.size:
            h.update(a.reshape(-1).view(np.uint8).data)  # the bytes, without a copy
    elif isinstance(x, tuple | list):
        h.update(b"(")
        for v in x:
            _key_part(v, h)
        h.update(b")")
    elif hasattr(x, "kernel") and hasattr(x, "t_span"):  # an slbasis.Basis
        # repr(x) rounds the floats; the exact values of the mapping are added
        exact = tuple(
            float(v) if np.ndim(v) == 0 else tuple(map(float, v))
            for v in (getattr(x, "scale", 0.0), getattr(x, "centre", 0.0), x.t_span)
        )
        h.update(repr((repr(x), exact, _kernel_key(x.kernel))).encode())
    else:
        h.update(repr(x).encode())


def _hasher() -> Any:
    """The hash of the keys: SHA-256 (FIPS 180-4).

    Current x86-64 and ARM processors run its compression function in hardware (SHA
    extensions), which makes it faster than BLAKE2b there, and the keys of one fit hash
    megabytes of arrays.  Accidental collisions of its 256 bits are out of the question.
    """
    return hashlib.sha256()


def digest(x: Any) -> bytes:
    """The content key of ``x``: a SHA-256 digest of its contents.

    Arrays are keyed by their bytes, shapes and dtypes, never by identity (a caller may
    reuse a buffer); objects with ``cache_key()`` by what it returns; other values by their
    ``repr`` (module docstring).

    Parameters
    ----------
    x : object
        An array, a tuple or list of keyable values, an object with ``cache_key()``, a
        basis, or any value with a faithful ``repr``.

    Returns
    -------
    bytes
        The 32-byte digest.

    Examples
    --------
    >>> digest(np.zeros(3)) == digest(np.zeros(3)), digest(np.zeros(3)) == digest(np.zeros(4))
    (True, False)
    """
    h = _hasher()
    _key_part(x, h)
    return h.digest()


def _read_only(x: Any) -> Any:
    if isinstance(x, np.ndarray):
        x.flags.writeable = False
    elif isinstance(x, tuple | list):
        for v in x:
            _read_only(v)
    elif dataclasses.is_dataclass(x) and not isinstance(x, type):
        for f in dataclasses.fields(x):
            _read_only(getattr(x, f.name))
    return x


#: the caches of every memoised function, for :func:`clear_caches`
_CACHES: list[OrderedDict] = []


def clear_caches() -> None:
    """Empty the caches of every memoised function.

    The memory they hold is released, and the next call on the same data computes
    everything again (benchmarks timing several methods on one record clear them between
    the methods, so that none is timed on another's projection).
    """
    for cache in _CACHES:
        cache.clear()


def memoize(func: F | None = None, *, size: int = CACHE_SIZE) -> Any:
    """Cache ``func`` by the contents of its arguments, keeping the ``size`` most recent
    results.

    Use as ``@memoize`` or ``@memoize(size=...)``.  The key is the digest of the arguments
    (:func:`digest`); a call with an argument that cannot be keyed (``cache_key()`` returned
    None) is computed without the cache.  Results are made read-only, so that a caller
    cannot corrupt a shared result.

    Parameters
    ----------
    func : callable, optional
        The function (omitted when called with ``size`` only).
    size : int, optional
        Results kept (least recently used dropped first).

    Returns
    -------
    callable
        The memoised function (with ``cache_clear()``), or a decorator when ``func`` is
        omitted.

    Examples
    --------
    >>> calls = []
    >>> @memoize(size=2)
    ... def double(x):
    ...     calls.append(1)
    ...     return 2 * x
    >>> double(np.arange(3.0)), double(np.arange(3.0)), len(calls)
    (array([0., 2., 4.]), array([0., 2., 4.]), 1)
    """
    if func is None:
        return functools.partial(memoize, size=size)
    cache: OrderedDict[bytes, tuple[Any, Any]] = OrderedDict()
    _CACHES.append(cache)

    @functools.wraps(func)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        h = _hasher()
        try:
            _key_part(args, h)
            _key_part(sorted(kwargs.items()), h)
        except _Uncacheable:
            return func(*args, **kwargs)
        key = h.digest()
        if key in cache:
            cache.move_to_end(key)
            return cache[key][0]
        out = _read_only(func(*args, **kwargs))
        # keep the arguments' kernels alive so that their ids in the key stay unique
        cache[key] = (out, [a.kernel for a in args if hasattr(a, "kernel")])
        if len(cache) > size:
            cache.popitem(last=False)
        return out

    wrapper.cache_clear = cache.clear  # type: ignore[attr-defined]
    return wrapper  # type: ignore[return-value]


def _pseudo(lag: LagOperator, rows: Any) -> BlockPseudo | None:
    return BlockPseudo(lag, rows) if rows is not None else None  # type: ignore[arg-type]


@memoize(size=STAGE_CACHE_SIZE)
def past_window_aic(
    U: Any, Y: Any, p_max: int, p_min: int, lag: LagOperator, rows: Any, feedthrough: bool
) -> tuple[int, Any]:
    """:func:`hdpbsid.core.blocks.select_past_window_blocks` with pseudo-input rows, memoised.

    The criterion of every window depends on the data, the lag and the rows, not on the
    order, so every order of a sweep and the input-hold decision share it.

    Parameters
    ----------
    U : ndarray, shape (m, N)
        Input rows.
    Y : ndarray, shape (l, N)
        Output rows.
    p_max : int
        Largest window.
    p_min : int
        Smallest window.
    lag : LagOperator
        The (block) lag.
    rows : sequence of ndarray or None
        The pseudo-input rows, one array per block.
    feedthrough : bool
        Include ``D u_k``.

    Returns
    -------
    p : int
        The window of the smallest criterion.
    crit : ndarray, shape (p_max,)
        The criterion (read-only).
    """
    return select_past_window_blocks(
        U, Y, p_max, p_min=p_min, lag=lag, pseudo=_pseudo(lag, rows), feedthrough=feedthrough
    )


@memoize(size=STAGE_CACHE_SIZE)
def varx_stage(
    U: Any,
    Y: Any,
    p: int,
    lag: LagOperator,
    rows: Any,
    f: int,
    feedthrough: bool,
    regularize: Any,
    ridge_floor: float,
    instruments: Any,
) -> VarxStage:
    """:func:`hdpbsid.core.blocks.varx_stage_blocks` with pseudo-input rows, memoised.

    The VARX and the SVD of ``Gamma_f L_p Z_p`` do not depend on the order, which only
    truncates the decomposition: an order sweep runs them once per distinct ``(lag, p)``
    and every order gets the numbers it would get alone.

    Parameters
    ----------
    U : ndarray, shape (m, N)
        Input rows.
    Y : ndarray, shape (l, N)
        Output rows.
    p : int
        Past window.
    lag : LagOperator
        The (block) lag.
    rows : sequence of ndarray or None
        The pseudo-input rows, one array per block.
    f : int
        Future window.
    feedthrough : bool
        Include ``D u_k``.
    regularize : bool, str, float or None
        VARX regularisation.
    ridge_floor : float
        Lower bound of the GCV ridge.
    instruments : ndarray or None
        Instrument rows.

    Returns
    -------
    VarxStage
        The stage (arrays read-only).
    """
    return varx_stage_blocks(
        U, Y, p, lag, _pseudo(lag, rows), f, feedthrough, regularize, ridge_floor, instruments
    )
