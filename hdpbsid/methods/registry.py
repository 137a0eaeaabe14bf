"""The method registry: method names and the functions that identify with them.

Methods live in :data:`METHODS` (name -> callable with the call shape ``func(t, u, y,
order=None, **options) -> StateSpaceModel``, the public front door).  Inside the package a
method is called in its second shape, ``fit(data, order=None, **settings)`` on one
:class:`~hdpbsid.data.records.Dataset` (one record is a Dataset of one
:class:`~hdpbsid.data.records.Record`): :func:`get_fit` gives it.  A built-in method's
front door carries its Dataset function as the attribute ``fit``
(``identify_hermite.fit is fit_hermite``); a method registered with the front-door shape
only is called with the record's arrays (:func:`call_method`, :class:`FrontDoor`).

* every built-in method is registered *lazily* (:data:`LAZY_METHODS`), so a process
  that imports only this module (a worker of ``n_jobs``) knows them all: the first
  time ``"dt"`` (:mod:`hdpbsid.methods.dt`), ``"hermite"``
  (:mod:`hdpbsid.methods.hermite`), ``"laguerre"`` (:mod:`hdpbsid.methods.laguerre`),
  ``"legendre"``, ``"chebyshev"`` or ``"sl"`` (any finite-interval Sturm-Liouville
  family, option ``family=``; :mod:`hdpbsid.methods.sturm_liouville`) or ``"jacobi"``
  (:mod:`hdpbsid.methods.jacobi`) is asked for, the module
  is imported and its ``identify_<name>`` function registered.  A module may also call
  :func:`register_method` itself when imported;
* anything else can be added with :func:`register_method` (a user's own method, a
  wrapper around another tool for comparisons).

A leaf of the package: the methods are named by their module paths and imported on
first use, so the layers above (selection, the front end) reach every method through
this module without importing one another.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from hdpbsid.data.records import Dataset
from hdpbsid.models.model import StateSpaceModel

__all__ = [
    "IdentifyFunc",
    "DatasetFunc",
    "FrontDoor",
    "METHODS",
    "LAZY_METHODS",
    "register_method",
    "get_method",
    "get_fit",
    "dataset_call",
    "call_method",
    "is_available",
    "available_methods",
]

IdentifyFunc = Callable[..., StateSpaceModel]
#: The package's call shape of a method: ``fit(data: Dataset, order=None, **settings)``.
DatasetFunc = Callable[..., StateSpaceModel]

#: Registered methods: name -> ``func(t, u, y, order=None, **options)`` (the front door).
METHODS: dict[str, IdentifyFunc] = {}

#: Methods imported on first use: name -> candidate ``(module, function name)`` pairs,
#: tried in order (the first module that imports and has the function wins).
LAZY_METHODS: dict[str, tuple[tuple[str, str], ...]] = {
    "dt": (("hdpbsid.methods.dt", "identify_dt"),),
    "hermite": (("hdpbsid.methods.hermite", "identify_hermite"),),
    "laguerre": (("hdpbsid.methods.laguerre", "identify_laguerre"),),
    "legendre": (("hdpbsid.methods.sturm_liouville", "identify_legendre"),),
    "chebyshev": (("hdpbsid.methods.sturm_liouville", "identify_chebyshev"),),
    "sl": (("hdpbsid.methods.sturm_liouville", "identify_sl"),),
    "jacobi": (("hdpbsid.methods.jacobi", "identify_jacobi"),),
    "auto": (("hdpbsid.selection.auto", "identify_auto"),),
}


def register_method(name: str, func: IdentifyFunc, overwrite: bool = False) -> IdentifyFunc:
    """Register ``func`` under ``name`` in :data:`METHODS`.

    Re-registering a name with a different function is refused unless ``overwrite=True``
    (registering the same function twice is harmless, so a module may register itself on
    import).

    Parameters
    ----------
    name : str
        The method name (non-empty), as ``identify(..., method=name)`` takes it.
    func : callable
        ``func(t, u, y, order=None, **options)`` returning a
        :class:`~hdpbsid.models.model.StateSpaceModel` (a list of records, as a
        :class:`~hdpbsid.data.records.Dataset`, may come in ``t`` with ``u = y = None``).
        A function with an attribute ``fit``, ``fit(data, order=None, **settings)`` on a
        Dataset, is called that way inside the package (:func:`dataset_call`).
    overwrite : bool, optional
        Replace a different function registered under ``name``.

    Returns
    -------
    callable
        ``func`` (so the function can be used as a decorator's result).

    Raises
    ------
    TypeError
        If ``name`` is not a non-empty string or ``func`` is not callable.
    ValueError
        If ``name`` is taken by another function and ``overwrite`` is False.

    Examples
    --------
    >>> def identify_mine(t, u, y, order=None, **options):
    ...     return get_method("dt")(t, u, y, order=order, **options)
    >>> register_method("mine", identify_mine) is identify_mine
    True
    >>> is_available("mine")
    True
    >>> del METHODS["mine"]
    """
    if not isinstance(name, str) or not name:
        raise TypeError(f"name must be a non-empty string, got {name!r}")
    if not callable(func):
        raise TypeError(f"func must be callable, got {type(func).__name__}")
    old = METHODS.get(name)
    if old is not None and old is not func and not overwrite:
        raise ValueError(
            f"method {name!r} is already registered ({getattr(old, '__qualname__', old)}); "
            f"pass overwrite=True to replace it"
        )
    METHODS[name] = func
    return func


def _load_lazy(name: str) -> IdentifyFunc | None:
    """Import a lazily registered method; ``None`` if none of its modules exists."""
    for module_name, func_name in LAZY_METHODS[name]:
        try:
            module = importlib.import_module(module_name)
        except ModuleNotFoundError as exc:
            if exc.name == module_name:
                continue
            raise  # the module exists but one of *its* imports is missing: show that
        if name in METHODS:  # the module registered itself on import
            return METHODS[name]
        func = getattr(module, func_name, None)
        if func is not None:
            return register_method(name, func)
    return METHODS.get(name)


def get_method(name: str) -> IdentifyFunc:
    """The callable registered for ``name``, importing a lazy method on first use.

    Parameters
    ----------
    name : str
        The method name.

    Returns
    -------
    callable
        ``func(t, u, y, order=None, **options) -> StateSpaceModel``.

    Raises
    ------
    TypeError
        If ``name`` is not a string.
    ValueError
        If the name is unknown, or its module cannot be imported (the message lists the
        available methods).

    Examples
    --------
    >>> get_method("hermite").__name__
    'identify_hermite'
    """
    if not isinstance(name, str):
        raise TypeError(f"method must be a string, got {type(name).__name__}")
    if name in METHODS:
        return METHODS[name]
    if name in LAZY_METHODS:
        func = _load_lazy(name)
        if func is not None:
            return func
        where = " or ".join(f"{mod}.{fn}" for mod, fn in LAZY_METHODS[name])
        raise ValueError(
            f"method {name!r} is not available: {where} could not be imported; "
            f"available methods: {available_methods()}"
        )
    raise ValueError(f"unknown method {name!r}; known methods: {available_methods()}")


def is_available(name: str) -> bool:
    """Whether ``name`` is registered or its lazy module imports.

    Parameters
    ----------
    name : str
        The method name.

    Returns
    -------
    bool
        True when :func:`get_method` would return a function.

    Examples
    --------
    >>> is_available("hermite"), is_available("no such method")
    (True, False)
    """
    if name in METHODS:
        return True
    return name in LAZY_METHODS and _load_lazy(name) is not None


def available_methods() -> list[str]:
    """Sorted names of the methods that can be used now (lazy ones are tried).

    Returns
    -------
    list of str
        The names.

    Examples
    --------
    >>> "hermite" in available_methods()
    True
    """
    for name in LAZY_METHODS:
        if name not in METHODS:
            _load_lazy(name)
    return sorted(METHODS)


@dataclass(frozen=True)
class FrontDoor:
    """A method known by its front door ``func(t, u, y, order=None, **options)`` only (a
    user's :func:`register_method`), called in the package's shape ``fit(data, order=None,
    **settings)``: several records are passed as the
    :class:`~hdpbsid.data.records.Dataset` in the ``t`` slot with ``u = y = None`` (the
    list form every method accepts), one record as its arrays: the absolute times
    ``t0 + t``, the input (None for a time series, ``u`` with no column) and the output.
    A caller that holds the arrays the Dataset was made of passes them instead
    (:func:`call_method`).

    Parameters
    ----------
    func : callable
        The method's front door.

    Examples
    --------
    >>> import numpy as np
    >>> seen = []
    >>> door = FrontDoor(lambda t, u, y, order=None: seen.append((t[0], u, order)))
    >>> t = 10.0 + np.arange(20) * 0.5
    >>> door(Dataset.of(t, None, np.sin(t)), order=2)
    >>> seen
    [(np.float64(10.0), None, 2)]
    """

    func: IdentifyFunc

    def __call__(self, data: Dataset, order: int | None = None, **settings: Any) -> Any:
        """Run the front door on ``data`` (the class docstring says how).

        Parameters
        ----------
        data : Dataset
            The records.
        order : int or None, optional
            The model order.
        **settings
            The method's keywords.

        Returns
        -------
        StateSpaceModel
            What the method returns.
        """
        if len(data) > 1:
            return self.func(data, None, None, order=order, **settings)
        r = data.records[0]
        u = None if r.u.shape[1] == 0 else r.u
        return self.func(r.t0 + r.t, u, r.y, order=order, **settings)


def dataset_call(func: IdentifyFunc) -> DatasetFunc:
    """The Dataset shape ``fit(data, order=None, **settings)`` of the method ``func``.

    Parameters
    ----------
    func : callable
        A registered method (its front door).

    Returns
    -------
    callable
        ``func.fit`` when the method has a Dataset function (every built-in one), else
        ``func`` behind a :class:`FrontDoor`.

    Examples
    --------
    >>> dataset_call(get_method("hermite")).__name__
    'fit_hermite'
    >>> isinstance(dataset_call(lambda t, u, y, order=None: None), FrontDoor)
    True
    """
    fit = getattr(func, "fit", None)
    return fit if callable(fit) else FrontDoor(func)


def call_method(
    func: IdentifyFunc,
    arrays: tuple[Any, Any, Any],
    data: Dataset | Callable[[], Dataset],
    order: int | None = None,
    **settings: Any,
) -> Any:
    """Run the registered method ``func`` in its own call shape on a record the caller
    holds both ways: its Dataset function on ``data``, a front door (a user's method) on
    ``arrays``, what such a method was always given, bit for bit.

    Parameters
    ----------
    func : callable
        A registered method (its front door).
    arrays : tuple
        ``(t, u, y)`` as the caller has them (a list of records, or a Dataset, in the
        ``t`` slot with ``u = y = None`` for several).
    data : Dataset or callable
        The Dataset of ``arrays``, or a function making it (called only for a Dataset
        function: a front door's record is not checked here).
    order : int or None, optional
        The model order.
    **settings
        The method's keywords.

    Returns
    -------
    StateSpaceModel
        What the method returns.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.arange(300) * 0.1
    >>> u = np.sign(np.sin(0.7 * t))
    >>> y = np.convolve(u, np.exp(-t[:50]), "full")[:300] * 0.1
    >>> rec = (t, u, y)
    >>> call_method(get_method("dt"), rec, lambda: Dataset.of(*rec), order=1).n
    1
    """
    fit = getattr(func, "fit", None)
    if not callable(fit):
        return func(*arrays, order=order, **settings)
    return fit(data if isinstance(data, Dataset) else data(), order=order, **settings)


def get_fit(name: str) -> DatasetFunc:
    """The method registered for ``name`` in the package's call shape (:func:`dataset_call`).

    Parameters
    ----------
    name : str
        The method name.

    Returns
    -------
    callable
        ``fit(data: Dataset, order=None, **settings) -> StateSpaceModel``.

    Raises
    ------
    TypeError, ValueError
        As :func:`get_method` raises them.

    Examples
    --------
    >>> get_fit("dt").__name__
    'fit_dt'
    """
    return dataset_call(get_method(name))
