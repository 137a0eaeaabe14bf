"""Compiled kernels without the first-call wait: numpy runs while numba compiles apart.

numba compiles a kernel on its first call and caches the machine code on disk
(``cache=True``: in ``__pycache__`` next to the module, or numba's user-wide cache
directory when the package directory is not writable, or ``NUMBA_CACHE_DIR``).  With an
empty cache the first call of a fresh installation waited for every kernel it touched
(tens of seconds), far longer than the numpy evaluation of the same call.  So, for the
engine ``"auto"``:

* a kernel module is **ready** when each of its kernels (the dispatchers named in its
  ``WARM_SIGNATURES``) is compiled in this process or has machine code in numba's cache
  for the current source (:func:`ready`); then the compiled engine runs;
* otherwise the call runs with numpy, and one **background process** (at low priority)
  compiles every registered kernel module into the cache (:func:`warm`, the signatures
  each module lists in ``WARM_SIGNATURES``, without running anything); later calls, and
  later processes, find the cache filled.

``python -m slbasis.numeric.jit MODULE ...`` (``make`` runs it on installation) fills the
cache ahead of time.  An explicit ``engine="numba"`` compiles on the call as before.  The
private numba attributes read here (a dispatcher's cache index) are guarded: should they
change, a module counts as ready and numba compiles on the call, as without this module.
"""

from __future__ import annotations

import os
import subprocess
import sys
import threading
from types import ModuleType
from typing import Any

__all__ = ["array", "register", "registered", "cached", "ready", "warm", "main"]

#: the kernel modules the background process compiles (names; imported only there)
_REGISTERED: list[str] = ["slbasis.numeric.compiled"]
_lock = threading.Lock()
_ready: set[str] = set()
_process: dict[str, Any] = {"proc": None}


def array(dtype: Any, ndim: int, layout: str = "C", readonly: bool = False) -> Any:
    """numba's type of a NumPy array argument, for a module's ``WARM_SIGNATURES``.

    Parameters
    ----------
    dtype : numba type
        Element type (``numba.types.float64``, ...).
    ndim : int
        Number of dimensions.
    layout : str
        ``"C"`` (contiguous) or ``"A"`` (any strides), as numba types the argument.
    readonly : bool
        Whether the array arrives read-only (a separate compilation in numba).

    Returns
    -------
    numba.types.Array
    """
    import numba

    return numba.types.Array(dtype, ndim, layout, readonly=readonly)


def register(*names: str) -> None:
    """Add kernel modules (by import name) to those the background process compiles.

    Each module defines ``WARM_SIGNATURES``: ``{dispatcher name: [argument types, ...]}``.

    Parameters
    ----------
    *names : str
        Import names of kernel modules; a name registered before is not added twice.
    """
    with _lock:
        for name in names:
            if name not in _REGISTERED:
                _REGISTERED.append(name)


def registered() -> list[str]:
    """The registered kernel modules, in registration order.

    Returns
    -------
    list of str
        Their import names.

    Examples
    --------
    >>> "slbasis.numeric.compiled" in registered()
    True
    """
    return list(_REGISTERED)


def _has_cache_entry(dispatcher: Any) -> bool:
    """Whether numba's on-disk cache holds code of ``dispatcher`` for its current source."""
    try:
        index = dispatcher._cache._cache_file._load_index()
    except Exception:  # numba's internals changed: let the call compile as before
        return True
    return bool(index)


def cached(module: ModuleType) -> bool:
    """Whether every kernel of ``module`` is compiled in this process or cached on disk.

    Parameters
    ----------
    module : module
        A kernel module with ``WARM_SIGNATURES``.

    Returns
    -------
    bool
        True when no kernel would compile on its first call.
    """
    for name in module.WARM_SIGNATURES:
        dispatcher = getattr(module, name)
        if not dispatcher.signatures and not _has_cache_entry(dispatcher):
            return False
    return True


def _start_background() -> None:
    """Start (once per process) the process that compiles the registered modules."""
    if _process["proc"] is not None:
        return
    # the same module files as this process (a script may have changed sys.path)
    path = os.pathsep.join(p for p in sys.path if p)
    env = dict(os.environ, PYTHONPATH=path)
    try:
        _process["proc"] = subprocess.Popen(
            [sys.executable, "-m", "slbasis.numeric.jit", "--background", *_REGISTERED],
            env=env,
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            start_new_session=True,  # finishes the cache even if this process ends first
        )
    except OSError:
        _process["proc"] = False  # cannot spawn: the calls compile as before


def ready(module: ModuleType) -> bool:
    """Whether the engine ``"auto"`` should run ``module``'s compiled kernels now.

    True when they are compiled or cached (:func:`cached`); else starts the background
    compilation (once per process) and returns False, so the call runs with numpy.  True as
    well when no background process can be started, or it failed (the call compiles).

    Parameters
    ----------
    module : module
        A kernel module with ``WARM_SIGNATURES``.

    Returns
    -------
    bool
        Whether to run the compiled kernels.
    """
    name = module.__name__
    if name in _ready:
        return True
    with _lock:
        if cached(module):
            _ready.add(name)
            return True
        _start_background()
        proc = _process["proc"]
        # no background process, or it failed: the call compiles, as without this module
        return proc is False or proc.poll() not in (None, 0)


def warm(module: ModuleType) -> int:
    """Compile (into numba's cache) every signature of ``module.WARM_SIGNATURES``.

    Parameters
    ----------
    module : module
        A kernel module with ``WARM_SIGNATURES``.

    Returns
    -------
    int
        The number of signatures compiled.
    """
    count = 0
    for name, signatures in module.WARM_SIGNATURES.items():
        dispatcher = getattr(module, name)
        for sig in signatures:
            dispatcher.compile(tuple(sig))
            count += 1
    return count


def main(argv: list[str] | None = None) -> int:
    """``python -m slbasis.numeric.jit [--background] MODULE ...``: fill numba's cache with the
    kernels of the modules (default: the registered ones).

    Parameters
    ----------
    argv : list of str, optional
        The arguments (default ``sys.argv[1:]``); ``--background`` lowers the priority and
        prints nothing.

    Returns
    -------
    int
        The exit code, 0.
    """
    import importlib

    args = list(sys.argv[1:] if argv is None else argv)
    background = "--background" in args
    names = [a for a in args if a != "--background"] or registered()
    if background and hasattr(os, "nice"):
        os.nice(10)  # leave the cores to the process that asked
    for name in names:
        module = importlib.import_module(name)
        n = warm(module)
        if not background:
            print(f"compiled {n} kernel signature(s) of {name}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
