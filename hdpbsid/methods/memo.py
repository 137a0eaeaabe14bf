"""Content-keyed memoisation of the expensive, order-independent steps of the methods.

Choosing an order (or a method) identifies the same record several times with different
orders.  The projection of the record onto the basis and the basis-domain operators do
not depend on the order, so they are computed once: :func:`memoize` caches a function's
result under a key made of the *contents* of its array arguments (a BLAKE2 digest of
their bytes, shapes and dtypes) and the ``repr`` of every other argument, keeping the
most recent :data:`CACHE_SIZE` results per function.  Arrays are never compared by
identity (a caller may reuse a buffer), and the cached arrays are made read-only, so a
caller that tried to modify a shared result would get an error instead of corrupting
the cache.
"""

from __future__ import annotations

import functools
import hashlib
from collections import OrderedDict
from collections.abc import Callable
from typing import Any, TypeVar

import numpy as np

__all__ = ["memoize", "CACHE_SIZE"]

#: results kept per memoised function: one order/method selection touches two records
#: (the estimation part and the whole record) with up to two input holds
CACHE_SIZE = 8

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
    if isinstance(x, np.ndarray):
        a = np.ascontiguousarray(x)
        h.update(repr((a.shape, a.dtype.str)).encode())
        h.update(a.view(np.uint8).tobytes() if a.size else b"")
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


def _read_only(x: Any) -> Any:
    if isinstance(x, np.ndarray):
        x.flags.writeable = False
    elif isinstance(x, tuple | list):
        for v in x:
            _read_only(v)
    return x


def memoize(func: F) -> F:
    """Cache ``func`` by the contents of its arguments (module docstring)."""
    cache: OrderedDict[bytes, tuple[Any, Any]] = OrderedDict()

    @functools.wraps(func)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        h = hashlib.blake2b(digest_size=20)
        _key_part(args, h)
        _key_part(sorted(kwargs.items()), h)
        key = h.digest()
        if key in cache:
            cache.move_to_end(key)
            return cache[key][0]
        out = _read_only(func(*args, **kwargs))
        # keep the arguments' kernels alive so that their ids in the key stay unique
        cache[key] = (out, [a.kernel for a in args if hasattr(a, "kernel")])
        if len(cache) > CACHE_SIZE:
            cache.popitem(last=False)
        return out

    wrapper.cache_clear = cache.clear  # type: ignore[attr-defined]
    return wrapper  # type: ignore[return-value]
