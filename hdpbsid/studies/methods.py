"""The identification methods compared in the studies, by study name.

``"hermite"`` is HD-PBSID (the thesis, §3.2), ``"laguerre"`` CT-PBSID with projected
Laguerre coefficients and ``"laguerre-filter"`` CT-PBSID with the Laguerre filter
network (the thesis, §3.1; Bergamasco & Lovera 2011), ``"dt"`` discrete-time PBSID of the
samples converted to continuous time.  Every one runs through :func:`hdpbsid.identify`
with its defaults, plus the study's explicit options, so improvements to the method
defaults are picked up by the studies.
"""

from __future__ import annotations

from typing import Any

from hdpbsid.identify import identify
from hdpbsid.models.model import StateSpaceModel

__all__ = ["METHODS", "identify_with", "check_methods"]

#: study method name -> (``identify`` method, fixed options)
METHODS: dict[str, tuple[str, dict[str, Any]]] = {
    "hermite": ("hermite", {}),
    "laguerre": ("laguerre", {"variant": "projection"}),
    "laguerre-filter": ("laguerre", {"variant": "filter"}),
    "dt": ("dt", {}),
    "legendre": ("legendre", {}),
    "chebyshev": ("chebyshev", {}),
}

#: labels used in tables and figures
LABELS: dict[str, str] = {
    "hermite": "HD-PBSID (Hermite)",
    "laguerre": "CT-PBSID (Laguerre projection)",
    "laguerre-filter": "CT-PBSID (Laguerre filters)",
    "dt": "DT PBSID + d2c",
    "legendre": "Legendre PBSID",
    "chebyshev": "Chebyshev PBSID",
}


def check_methods(methods: Any) -> tuple[str, ...]:
    """Check a non-empty sequence of study method names.

    Parameters
    ----------
    methods : str or sequence of str
        Names from :data:`METHODS` (a single string is one method).

    Returns
    -------
    tuple of str
        The names.

    Raises
    ------
    TypeError
        If ``methods`` is not a sequence of strings.
    ValueError
        If it is empty or names an unknown method.

    Examples
    --------
    >>> check_methods("dt")
    ('dt',)
    """
    if isinstance(methods, str):
        methods = (methods,)
    try:
        names = tuple(methods)
    except TypeError as exc:
        raise TypeError(f"methods must be a sequence of names from {list(METHODS)}") from exc
    bad = [m for m in names if m not in METHODS]
    if not names or bad:
        raise ValueError(f"methods must be names from {list(METHODS)}, got {list(names)}")
    return names


def identify_with(
    name: str, t: Any, u: Any, y: Any, order: int | None, options: dict[str, Any] | None = None
) -> StateSpaceModel:
    """Identify with a study method: ``identify(t, u, y, order, method=..., **fixed, **options)``.

    Parameters
    ----------
    name : str
        A key of :data:`METHODS` (the ``identify`` method and its fixed options).
    t : array_like, shape (Ns,)
        Sample times.
    u : array_like, shape (Ns, m)
        Input.
    y : array_like, shape (Ns, l)
        Output.
    order : int or None
        Model order (``None``: chosen by the method).
    options : dict, optional
        Further options of :func:`hdpbsid.identify`.

    Returns
    -------
    StateSpaceModel
        The identified model.
    """
    method, fixed = METHODS[name]
    # the studies' records are simulated from rest around a zero operating point, as in
    # the thesis: no levels to remove (mean removal would add an O(1/T) level error)
    opts = {"detrend": None, **fixed, **(options or {})}
    return identify(t, u, y, order, method=method, **opts)
