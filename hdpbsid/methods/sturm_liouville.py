"""Methods ``"legendre"``, ``"chebyshev"`` and any finite-interval ``slbasis`` basis.

PBSID in a Sturm-Liouville basis on the record window (the general theory of the thesis,
§4, and the Legendre/Jacobi bases its §7 names as future research; docs/theory.md, "Any
finite-interval Sturm-Liouville basis").  On a finite window the projected
derivative is nilpotent (Legendre: ``phi_n'`` lies in ``span{phi_0..phi_{n-1}}``), so the
Hermite construction ``M = ((D/alpha + beta I)/gamma)^{-1}`` would be a polynomial in ``D``
with norm ``~ (N^2 / (alpha T))^k``: it amplifies noise instead of averaging it.  We use
the **causal integration operator** ``J`` instead (row form: ``X J`` are the coefficients
of ``int_{t0}^t x``; Legendre: tridiagonal, ``int P_n = (P_{n+1} - P_{n-1})/(2n+1)``) and
its Möbius map

    M = m(J) = alpha gamma J (I + alpha beta J)^{-1},

the coefficient form of the causal first-order filter ``alpha gamma / (s + alpha beta)``
(``J <-> 1/s``).  From ``x(t) = x(t0) + int (A x + B u + K e)``, adding ``alpha beta int x``
and applying ``(I + alpha beta J)^{-1}``:

    X = A' X M + B' U M + K' E M + x(t0) 1 (I + alpha beta J)^{-1} + (truncation),

with the same ``A' = (A/alpha + beta I)/gamma``, ``B' = B/(alpha gamma)``,
``K' = K/(alpha gamma)`` as HD-PBSID and the same map back.  **Why it is stable**: the map
``lambda -> lambda' = (lambda/alpha + beta)/gamma`` sends the disc of radius
``alpha gamma`` about ``-alpha beta`` onto the unit disc (for ``beta = gamma = 1`` the
disc ``|lambda + alpha| < alpha``, tangent to the imaginary axis at 0: it holds the stable
eigenvalues of moderate size, e.g. real ones in ``(-2 alpha, 0)``; unstable ones map
outside, which is harmless because the core's truncation concerns the predictor
``A - K C``, stable by construction), and ``M`` is a causal
convolution with ``alpha gamma e^{-alpha beta t}``, whose L^1 norm is ``gamma / beta = 1``:
``M`` is a contraction, so the regressors ``Z M^j`` are repeated low-pass filterings
("integrations") of the data.

The initial-state term and the truncation of the cut ``J`` (Legendre: the last column,
``X_N J[N, N-1]``) are pseudo-inputs ``w`` with ``w M = v``, i.e. ``w = v J^{-1}``
(``v = 1`` coefficients, resp. ``e_{N-1}``).  ``J`` is exact for Legendre, in closed form
and tridiagonal (:func:`slbasis.numeric.operators.integration_matrix`), so ``W -> W M`` and
``w J = v`` are banded solves, ``O(N)`` per row; for a family whose derivatives stay in
the span it comes from the exact derivative matrix; for other families (Chebyshev,
Gegenbauer, Jacobi functions in ``L^2(dt)``, custom problems) it is computed by quadrature
in ``x = -cos(theta)``, and the truncation is then only approximately confined to the
last column (accurate when the coefficients decay, i.e. for smooth signals and ``N``
above the bandwidth).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hdpbsid.bases.basis_domain import (
    P_DEFAULT_RANGE,
    bandwidth,
    resolve_holds,
)
from hdpbsid.bases.family import Choice, Integrator, size_policy
from hdpbsid.bases.operator_scale import AlphaRule
from hdpbsid.bases.pipeline import make_blocks, one_or_all, project, solve
from hdpbsid.bases.segments import default_window, records_bandwidth
from hdpbsid.bases.settings import BasisSettings, resolve_settings
from hdpbsid.bases.sl_family import SturmLiouvilleFamily, integration_matrix
from hdpbsid.data.checks import check_order, check_positive_int
from hdpbsid.data.records import Dataset, Record, as_records
from hdpbsid.methods.hermite import _real
from hdpbsid.models.model import StateSpaceModel
from hdpbsid.runtime import library_call

__all__ = [
    "identify_sl",
    "identify_legendre",
    "identify_chebyshev",
    "fit_sl",
    "fit_legendre",
    "fit_chebyshev",
    "integration_matrix",
    "SturmLiouvilleFamily",
    "default_alpha",
    "default_past_window",
]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class DefaultAlpha:
    """The default pole of the integrator (:func:`default_alpha`): ``alpha = factor *
    omega_y``, ``omega_y`` the largest bandwidth holding ``output_fraction`` of an
    output's energy.

    Attributes
    ----------
    factor : float
        ``alpha`` relative to the output bandwidth.
    output_fraction : float
        The fraction of an output's energy the bandwidth holds.

    Examples
    --------
    >>> DefaultAlpha()
    DefaultAlpha(factor=0.5, output_fraction=0.95)
    """

    #: the map's disc ``|lambda + alpha| < alpha`` holds real eigenvalues in
    #: ``(-2 alpha, 0)`` (module docstring): half the bandwidth puts the modes within it
    factor: float = 0.5
    #: the band of the dynamics, not of the noise floor: the band holding all of a noisy
    #: output's energy is the whole band the noise covers
    output_fraction: float = 0.95


#: the rule of :func:`default_alpha`
DEFAULT_ALPHA = DefaultAlpha()
#: default alpha = ALPHA_FACTOR * (bandwidth holding OUTPUT_FRACTION of the output energy)
ALPHA_FACTOR = DEFAULT_ALPHA.factor
OUTPUT_FRACTION = DEFAULT_ALPHA.output_fraction


@library_call
def identify_sl(
    t: Any,
    u: Any = None,
    y: Any = None,
    order: int | None = None,
    *,
    family: Any = "legendre",
    N: int | None = None,
    alpha: float | None = None,
    beta: float = 1.0,
    gamma: float = 1.0,
    family_params: dict | None = None,
    settings: BasisSettings | None = None,
    **shared: Any,
) -> StateSpaceModel:
    r"""PBSID in a finite-interval Sturm-Liouville basis on the record window.

    On a finite window the projected derivative is nilpotent, so the Hermite construction
    would amplify noise; the lag is instead the Möbius map ``M = alpha gamma J (I + alpha
    beta J)^{-1}`` of the causal integration matrix ``J``, the coefficient form of the causal
    filter ``alpha gamma / (s + alpha beta)``, a contraction (module docstring).  Each
    record, or window of a long record, gets its own basis on its own window with its own
    initial-state and truncation pseudo-inputs (common ``alpha``), all stacked in one PBSID
    problem.  Every choice is reported, with its reason, in ``model.options``.

    Parameters
    ----------
    t : array_like, shape (Ns,), or list of records
        Increasing sample times; or a list of ``(t_i, u_i, y_i)`` records (``u = y = None``).
    u : array_like, shape (Ns, m), optional
        Inputs.
    y : array_like, shape (Ns, l)
        Outputs.
    order : int, optional
        Model order; None: the largest log-gap of the singular values (orders ``1..min(
        max_order, f l - 1)``).
    family : str, slbasis.SturmLiouville or SturmLiouvilleFamily, optional
        An ``slbasis`` catalogue name with a finite interval (``"legendre"``,
        ``"chebyshev_t"``, ``"chebyshev_u"``, ``"gegenbauer"``, ``"jacobi"``), a problem, or
        a :class:`~hdpbsid.bases.sl_family.SturmLiouvilleFamily` (``family_params`` then
        unused).
    N : int, optional
        Basis size; None: ``N = 1.5 * bandwidth * T / 2`` clipped to ``[50, 2000]`` and to
        ``Ns / 2`` (a ``RuntimeWarning`` when an upper limit binds).  A given ``N`` whose band
        ``2 N / T`` is below the data bandwidth is refused.
    alpha : float, optional
        The integrator's pole (rad per time unit); None: :func:`default_alpha`.
    beta : float, optional
        Shift of the integrator form, ``> 0``.
    gamma : float, optional
        Gain of the integrator form, ``> 0``.
    family_params : dict, optional
        The family's parameters (e.g. ``{"lam": 1.5}`` for Gegenbauer).
    settings : BasisSettings, optional
        The shared settings (:class:`~hdpbsid.bases.settings.BasisSettings`).
    **shared
        The shared settings as keywords (as in
        :func:`hdpbsid.methods.hermite.identify_hermite`); the default past window is
        :func:`default_past_window`, ``f = p``; ``input_hold="auto"`` judges ``zoh`` against
        ``foh`` by the AIC of the VARX fit over HD-PBSID's preferred range of windows (a test
        of the input's interpolant, for which a longer VARX approximates the innovations
        better, not the variance choice of this method's own ``p``).

    Returns
    -------
    StateSpaceModel
        The continuous-time model; ``options`` reports the family, the integration matrix's
        construction and every choice.

    Raises
    ------
    ValueError
        If an argument is out of range, ``N`` does not resolve the data band, the family
        lives on an infinite interval, or the outputs have no bandwidth to choose ``alpha``.
    TypeError
        If an argument has the wrong type, the family is not accepted, or a keyword is not a
        shared setting.

    Notes
    -----
    From :math:`x(t) = x(t_0) + \int (A x + B u + K e)`, adding :math:`\alpha\beta \int x`
    and applying :math:`(I + \alpha\beta J)^{-1}`:

    .. math::

        X = A' X M + B' U M + K' E M + x(t_0)\,\mathbf{1}(I + \alpha\beta J)^{-1}
            + (\text{truncation}),
        \qquad M = \alpha\gamma J (I + \alpha\beta J)^{-1},

    with ``A'``, ``B'``, ``K'`` and the map back as in HD-PBSID.  ``M`` is the causal
    convolution with :math:`\alpha\gamma e^{-\alpha\beta t}`, of :math:`L^1` norm
    :math:`\gamma/\beta`, so the regressors :math:`Z M^j` are repeated low-pass filterings of
    the data.

    References
    ----------
    .. [1] A. Zettl, *Sturm-Liouville Theory*, Mathematical Surveys and Monographs 121,
       AMS, 2005.
    .. [2] A. Chiuso, "The role of vector autoregressive modeling in predictor-based
       subspace identification", *Automatica* 43(6), 1034-1048, 2007.
    .. [3] G. Szego, *Orthogonal Polynomials*, 4th ed., AMS, 1975, ch. 4 (Legendre and
       Jacobi polynomials).

    Examples
    --------

    >>> from hdpbsid.systems.linear import second_order, simulate_zoh
    >>> A, B, C, D = second_order()  # eigenvalues -0.4 +- 1.9596j
    >>> t = np.arange(0.0, 40.0, 0.05)
    >>> u = (np.sin(0.7 * t) + np.sin(1.9 * t) + np.sin(3.1 * t))[:, None]
    >>> y = simulate_zoh(A, B, C, D, t, u)
    >>> model = identify_sl(t, u, y, order=2, family="legendre")
    >>> np.sort_complex(model.eigenvalues).round(2)
    array([-0.4-1.96j, -0.4+1.96j])
    >>> model.options["family"], model.options["N"]
    ('legendre', 99)
    """
    return fit_sl(
        Dataset.of(t, u, y), order, family=family, N=N, alpha=alpha, beta=beta, gamma=gamma,
        family_params=family_params, settings=settings, **shared,
    )  # fmt: skip


@library_call
def fit_sl(
    data: Dataset,
    order: int | None = None,
    *,
    family: Any = "legendre",
    N: int | None = None,
    alpha: float | None = None,
    beta: float = 1.0,
    gamma: float = 1.0,
    family_params: dict | None = None,
    settings: BasisSettings | None = None,
    **shared: Any,
) -> StateSpaceModel:
    """PBSID in a Sturm-Liouville basis on the records of ``data``: :func:`identify_sl` in
    the registry's call shape (:func:`hdpbsid.methods.registry.get_fit`).

    Parameters
    ----------
    data : Dataset
        The records, checked (one record is a Dataset of one).
    order : int, optional
        Model order (:func:`identify_sl`).
    family : str or SturmLiouvilleFamily, optional
        The basis family.
    N : int, optional
        Basis size.
    alpha : float, optional
        Operator scale.
    beta : float, optional
        Shift of the integrator form.
    gamma : float, optional
        Gain of the integrator form.
    family_params : dict, optional
        Parameters of a named family.
    settings : BasisSettings, optional
        The shared settings.
    **shared
        The shared settings as keywords.

    Returns
    -------
    StateSpaceModel
        As :func:`identify_sl` returns it.
    """
    records = as_records(data)
    m, l = records[0].u.shape[1], records[0].y.shape[1]
    st = resolve_settings(settings, shared, "identify_sl")
    order = check_order(order)
    beta = _real(beta, "beta")
    gamma = _real(gamma, "gamma")
    N = None if N is None else check_positive_int(N, "N", 2)
    fam = (
        family
        if isinstance(family, SturmLiouvilleFamily)
        else SturmLiouvilleFamily(family, dict(family_params or {}))
    )
    wb = records_bandwidth(records)
    p_def = default_past_window(order, l)
    q = fam.q[st.boundary]
    blocks = make_blocks(
        records,
        fam,
        st.window,
        lambda: default_window(records, fam.size_rate(wb), q, p_def),
        size_policy(fam, N, wb),
    )
    given = None if alpha is None else Choice(_real(alpha, "alpha"), "given", AlphaRule.GIVEN)
    a = default_alpha(records) if given is None else given
    proj = project(blocks, resolve_holds(st.input_hold, m), st.n_jobs)
    bases = blocks.bases.values()
    options = {
        "method": fam.method,
        "family": fam.name,
        "family_params": dict(fam.params),
        **blocks.options(),
        "bandwidth": wb,
        "scale": blocks.seg_bases[0].scale,
        "centre": records[0].t0 + blocks.seg_bases[0].centre,
        "alpha_rule": a.reason,
        "boundary": st.boundary,
        "integration": one_or_all([fam.integration(b) for b in bases]),
        "window_padding": one_or_all([fam.padding(b) for b in bases]),
    }
    # the hold is judged as in the other basis methods (the VARX over the preferred
    # range of windows), not at this method's own small window: the same for every order
    op = Integrator(a.value, beta, gamma)
    fit = solve(proj, op, st, order, options, hold_range=P_DEFAULT_RANGE, p_range=(p_def, p_def))
    fit.model.report = fit.model.report.but(alpha=a)
    return fit.model


def default_past_window(order: int | None, l: int) -> int:
    """The default past window ``p = max(2, ceil(n / l))``: the smallest window that shows the
    order.

    ``n`` is the order, or 3 for order selection.  In this basis a lag is one more
    integration of the data, and the VARX regressors of neighbouring lags are strongly
    correlated: larger windows, or AIC over a wider range, gave erratic estimates at
    moderate SNR, where the smallest window that gives ``f l >= n`` rows of ``Gamma L`` did
    not.

    Parameters
    ----------
    order : int or None
        The model order, or None (order selection).
    l : int
        Number of outputs.

    Returns
    -------
    int
        The window.

    Examples
    --------
    >>> default_past_window(2, 1), default_past_window(5, 2), default_past_window(None, 1)
    (2, 3, 3)
    """
    need = order if order is not None else 3
    return max(2, -(-need // l))


def default_alpha(records: Sequence[Record]) -> Choice[float]:
    """The integrator's pole: ``alpha = ALPHA_FACTOR * omega_y``, ``omega_y`` the largest
    bandwidth holding ``OUTPUT_FRACTION`` of an output's energy.

    ``alpha`` belongs to the system's dynamics, not to the input: a step or ZOH input is
    broadband, and its band would put ``alpha`` far above the modes; the outputs are the
    input low-passed by the system, so their bandwidth is used.

    Parameters
    ----------
    records : sequence of Record
        The records (objects with ``t`` and ``y``).

    Returns
    -------
    Choice of float
        The pole and the rule.

    Raises
    ------
    ValueError
        When the outputs have no bandwidth (constant outputs): pass ``alpha``.
    """
    wy = max(bandwidth(r.t, r.y, OUTPUT_FRACTION) for r in records)
    if wy <= 0:
        raise ValueError("cannot choose alpha: the outputs have no bandwidth; pass alpha")
    return Choice(
        ALPHA_FACTOR * wy,
        f"{ALPHA_FACTOR} * output bandwidth ({OUTPUT_FRACTION:.0%} of the energy)",
    )


@library_call
def identify_legendre(
    t: Any, u: Any = None, y: Any = None, order: int | None = None, **options: Any
) -> StateSpaceModel:
    """PBSID with Legendre functions on the record window (method ``"legendre"``).

    :func:`identify_sl` with ``family="legendre"``: the integration matrix is exact and
    tridiagonal (``int P_n = (P_{n+1} - P_{n-1}) / (2n + 1)``), so the lag is a banded solve.

    Parameters
    ----------
    t : array_like, shape (Ns,), or list of records
        Sample times, or records.
    u : array_like, shape (Ns, m), optional
        Inputs.
    y : array_like, shape (Ns, l)
        Outputs.
    order : int, optional
        Model order; None selects it.
    **options
        Keywords of :func:`identify_sl` other than ``family``.

    Returns
    -------
    StateSpaceModel
        The continuous-time model.

    Raises
    ------
    TypeError
        If ``family`` is passed (use :func:`identify_sl`).

    Examples
    --------

    >>> from hdpbsid.systems.linear import second_order, simulate_zoh
    >>> A, B, C, D = second_order()  # eigenvalues -0.4 +- 1.9596j
    >>> t = np.arange(0.0, 40.0, 0.05)
    >>> u = (np.sin(0.7 * t) + np.sin(1.9 * t) + np.sin(3.1 * t))[:, None]
    >>> y = simulate_zoh(A, B, C, D, t, u)
    >>> np.sort_complex(identify_legendre(t, u, y, order=2).eigenvalues).round(2)
    array([-0.4-1.96j, -0.4+1.96j])
    """
    _family_fixed("identify_legendre", "legendre", options)
    return fit_legendre(Dataset.of(t, u, y), order, **options)


@library_call
def fit_legendre(data: Dataset, order: int | None = None, **options: Any) -> StateSpaceModel:
    """:func:`identify_legendre` on the records of ``data`` (the registry's call shape,
    :func:`hdpbsid.methods.registry.get_fit`).

    Parameters
    ----------
    data : Dataset
        The records, checked.
    order : int, optional
        Model order; None selects it.
    **options
        Keywords of :func:`fit_sl` other than ``family``.

    Returns
    -------
    StateSpaceModel
        The continuous-time model.

    Raises
    ------
    TypeError
        If ``family`` is passed.
    """
    _family_fixed("identify_legendre", "legendre", options)
    return fit_sl(data, order, family="legendre", **options)


def _family_fixed(func: str, family: str, options: dict[str, Any]) -> None:
    """Refuse a ``family`` among the keywords of a method whose family is fixed."""
    if "family" in options:
        raise TypeError(f"{func}: family is fixed to {family!r}; use identify_sl")


@library_call
def identify_chebyshev(
    t: Any, u: Any = None, y: Any = None, order: int | None = None, **options: Any
) -> StateSpaceModel:
    """PBSID with Chebyshev-T functions on the record window (method ``"chebyshev"``).

    :func:`identify_sl` with ``family="chebyshev_t"``: the functions are singular at the
    interval ends, so the basis window is padded, and the integration matrix comes from the
    derivative matrix or by quadrature (:func:`~hdpbsid.bases.sl_family.integration_matrix`).

    Parameters
    ----------
    t : array_like, shape (Ns,), or list of records
        Sample times, or records.
    u : array_like, shape (Ns, m), optional
        Inputs.
    y : array_like, shape (Ns, l)
        Outputs.
    order : int, optional
        Model order; None selects it.
    **options
        Keywords of :func:`identify_sl` other than ``family``.

    Returns
    -------
    StateSpaceModel
        The continuous-time model.

    Raises
    ------
    TypeError
        If ``family`` is passed (use :func:`identify_sl`).
    """
    _family_fixed("identify_chebyshev", "chebyshev_t", options)
    return fit_chebyshev(Dataset.of(t, u, y), order, **options)


@library_call
def fit_chebyshev(data: Dataset, order: int | None = None, **options: Any) -> StateSpaceModel:
    """:func:`identify_chebyshev` on the records of ``data`` (the registry's call shape,
    :func:`hdpbsid.methods.registry.get_fit`).

    Parameters
    ----------
    data : Dataset
        The records, checked.
    order : int, optional
        Model order; None selects it.
    **options
        Keywords of :func:`fit_sl` other than ``family``.

    Returns
    -------
    StateSpaceModel
        The continuous-time model.

    Raises
    ------
    TypeError
        If ``family`` is passed.
    """
    _family_fixed("identify_chebyshev", "chebyshev_t", options)
    return fit_sl(data, order, family="chebyshev_t", **options)


identify_sl.fit = fit_sl  # type: ignore[attr-defined]
identify_legendre.fit = fit_legendre  # type: ignore[attr-defined]
identify_chebyshev.fit = fit_chebyshev  # type: ignore[attr-defined]
