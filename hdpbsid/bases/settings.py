"""The settings every basis-domain method shares, in one validated object.

HD-PBSID (:func:`~hdpbsid.methods.hermite.identify_hermite`), CT-PBSID
(:func:`~hdpbsid.methods.laguerre.identify_laguerre`) and the finite-interval
Sturm-Liouville methods (:func:`~hdpbsid.methods.sturm_liouville.identify_sl`) differ in
their basis and lag operator only; the PBSID core they feed, the input-hold choice and the
windowing are the same.  Their shared settings live in :class:`BasisSettings`, checked
once when it is made; each method keeps its own basis keywords (``N``, ``alpha``, ``a``,
``family``, ...).  The methods take the shared settings either as keywords
(``identify_hermite(t, u, y, p=3)``) or as an object
(``identify_hermite(t, u, y, settings=BasisSettings(p=3))``); keywords override the
object's fields.

>>> from hdpbsid.bases.settings import BasisSettings
>>> s = BasisSettings(p=3, window=None)
>>> s.f is None, s.max_order
(True, 10)
>>> BasisSettings(p=0)
Traceback (most recent call last):
...
ValueError: p must be an integer >= 1, got 0
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, fields, replace
from typing import Any

import numpy as np

from hdpbsid.core.varx import parse_regularize
from hdpbsid.data.checks import DEFAULT_MAX_ORDER, check_positive_int, require_joblib

__all__ = ["BasisSettings", "INPUT_HOLDS", "SETTING_NAMES", "check_window", "resolve_settings"]

#: input-hold models of the projection (``"auto"`` fits ``zoh`` and ``foh``)
INPUT_HOLDS = ("auto", "zoh", "foh", "trapezoid")


def check_window(window: Any) -> float | str | None:
    """Validate the ``window`` setting.

    Parameters
    ----------
    window : float, "auto" or None
        None (records kept whole), ``"auto"`` (length from the band) or a positive length
        in seconds.

    Returns
    -------
    float, "auto" or None
        The setting, a number as ``float``.

    Raises
    ------
    ValueError
        If ``window`` is a string other than ``"auto"`` or a number that is not positive
        and finite.
    TypeError
        If ``window`` is neither None, a string nor a number (a bool is refused).

    Examples
    --------
    >>> check_window(5), check_window("auto"), check_window(None)
    (5.0, 'auto', None)
    """
    if window is None:
        return None
    if isinstance(window, str):
        if window != "auto":
            raise ValueError(f"window must be None, 'auto' or a length in seconds, got {window!r}")
        return window
    if isinstance(window, bool) or not isinstance(window, int | float | np.number):
        raise TypeError(f"window must be None, 'auto' or a number, got {type(window).__name__}")
    length = float(window)
    if not (np.isfinite(length) and length > 0):
        raise ValueError(f"window must be a positive length in seconds, got {window}")
    return length


def _check_flag(value: Any, name: str) -> bool:
    if not isinstance(value, bool | np.bool_):
        raise TypeError(f"{name} must be True or False, got {type(value).__name__}")
    return bool(value)


def _check_n_jobs(n_jobs: Any) -> int | None:
    """joblib's convention: None (serial), a positive count, or -1, -2, ... (all cores but)."""
    if n_jobs is None:
        return None
    if isinstance(n_jobs, bool) or not isinstance(n_jobs, int | np.integer):
        raise TypeError(f"n_jobs must be None or an int, got {type(n_jobs).__name__}")
    if n_jobs == 0:
        raise ValueError("n_jobs must be None, a positive count or negative (joblib), got 0")
    require_joblib(n_jobs)
    return int(n_jobs)


@dataclass(frozen=True)
class BasisSettings:
    """Settings of the PBSID core, the projection and the windowing that every basis
    method shares (validated on construction; frozen).

    Parameters
    ----------
    p, f : int or None
        Past and future windows of the VARX regression in the basis index; ``None``:
        ``p`` by AIC over 2..4 within the basis size, ``f = p``.
    max_order : int or None
        Largest order the singular-value rule considers (``None``: 10).
    boundary : bool
        Boundary rows ``phi(t0)``, ``phi(tN)`` as pseudo-inputs (the unknown initial and
        final states, eq. (4) of the thesis with the window terms).
    regularize : bool, str or float
        Ridge of the VARX regression: ``"gcv"``/``True`` (generalised cross-validation),
        ``"none"``/``False``/``None``, or a ridge parameter ``>= 0``.
    feedthrough : bool
        Estimate ``D`` (CT-PBSID always estimates its Laguerre-domain ``Dd``).
    stable_k : bool
        Replace the least-squares predictor gain by the Kalman (Riccati) gain, which makes
        the predictor ``A - K C`` stable.
    normalize : bool
        Scale the input and output rows to unit RMS before the regression.
    input_hold : str
        Inter-sample model of the input: ``"auto"`` (project ``zoh`` and ``foh``, keep
        the one whose VARX fit has the smaller AIC, one decision for every order),
        ``"zoh"``, ``"foh"``, ``"trapezoid"``.
    window : float, "auto" or None
        Window length (s) for long records, ``"auto"`` from the band, ``None`` whole.
    n_jobs : int or None
        joblib workers for projecting windows (None: serial).

    Raises
    ------
    ValueError
        If a window, order bound or ``n_jobs`` is out of range, ``regularize`` or
        ``input_hold`` is not one of the values above.
    TypeError
        If a flag is not a bool, or a setting is of the wrong type.

    Examples
    --------
    >>> s = BasisSettings(p=3, input_hold="zoh")
    >>> s.core_options(order=2)["p"], s.window
    (3, 'auto')
    """

    p: int | None = None
    f: int | None = None
    max_order: int = DEFAULT_MAX_ORDER
    boundary: bool = True
    regularize: bool | str | float | None = "gcv"
    feedthrough: bool = False
    stable_k: bool = False
    normalize: bool = True
    input_hold: str = "auto"
    window: float | str | None = "auto"
    n_jobs: int | None = None

    def __post_init__(self) -> None:
        def put(name: str, value: Any) -> None:
            object.__setattr__(self, name, value)

        for name in ("p", "f"):
            value = getattr(self, name)
            put(name, None if value is None else check_positive_int(value, name))
        put(
            "max_order",
            DEFAULT_MAX_ORDER
            if self.max_order is None
            else check_positive_int(self.max_order, "max_order"),
        )
        for name in ("boundary", "feedthrough", "stable_k", "normalize"):
            put(name, _check_flag(getattr(self, name), name))
        parse_regularize(self.regularize)
        if not isinstance(self.input_hold, str) or self.input_hold not in INPUT_HOLDS:
            raise ValueError(f"input_hold must be one of {INPUT_HOLDS}, got {self.input_hold!r}")
        put("window", check_window(self.window))
        put("n_jobs", _check_n_jobs(self.n_jobs))

    def core_options(self, order: int | None) -> dict[str, Any]:
        """The keywords of :func:`hdpbsid.bases.basis_domain.run_core`.

        Parameters
        ----------
        order : int or None
            The model order (None: selected).

        Returns
        -------
        dict
            ``order``, ``p``, ``f``, ``max_order``, ``regularize``, ``feedthrough``,
            ``stable_k``, ``normalize``.
        """
        return {
            "order": order,
            "p": self.p,
            "f": self.f,
            "max_order": self.max_order,
            "regularize": self.regularize,
            "feedthrough": self.feedthrough,
            "stable_k": self.stable_k,
            "normalize": self.normalize,
        }


#: names of the shared settings, for error messages and front ends
SETTING_NAMES = tuple(f.name for f in fields(BasisSettings))


def resolve_settings(
    settings: BasisSettings | None, overrides: Mapping[str, Any], method: str
) -> BasisSettings:
    """``settings`` with the keyword ``overrides`` applied, validated once.

    Parameters
    ----------
    settings : BasisSettings or None
        The settings object (None: the defaults).
    overrides : mapping of str to object
        Keyword arguments naming fields of :class:`BasisSettings`.
    method : str
        The method's name, for the error message.

    Returns
    -------
    BasisSettings
        The settings (a new object when there are overrides).

    Raises
    ------
    TypeError
        If ``settings`` is not a :class:`BasisSettings`, or an override names no setting
        (the message lists the valid ones).
    ValueError
        If an override's value is invalid (from :class:`BasisSettings`).

    Examples
    --------
    >>> resolve_settings(BasisSettings(p=3), {"f": 2}, "hermite").f
    2
    """
    if settings is None:
        settings = BasisSettings()
    elif not isinstance(settings, BasisSettings):
        raise TypeError(f"settings must be a BasisSettings, got {type(settings).__name__}")
    unknown = sorted(set(overrides) - set(SETTING_NAMES))
    if unknown:
        raise TypeError(
            f"{method}: unexpected keyword argument(s) {', '.join(unknown)}; the shared "
            f"settings are {', '.join(SETTING_NAMES)}"
        )
    return replace(settings, **overrides) if overrides else settings
