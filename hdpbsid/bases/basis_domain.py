"""Shared machinery of the basis-domain methods (HD-PBSID, CT-PBSID, Legendre PBSID).

The same PBSID core in a basis domain (docs/theory.md): the record is projected onto ``N``
orthonormal functions, signals become coefficient rows (rows = signals, columns = basis
index) and "one sample back" becomes a linear operator ``M`` on those rows.  This module
holds what the methods share:

* :class:`SolveLag` -- a :class:`~hdpbsid.core.varx.LagOperator` ``W -> W M^j`` where ``M`` is
  applied by a (banded) solve, never formed as a dense inverse;
* :class:`BlockShift` -- the sample shift inside blocks of columns (Laguerre filters);
* :func:`project_record` -- the coefficient rows of the sample interpolants;
* :func:`integrator_model` -- the model of the integrator form from the core's system;
* re-exported: the bandwidths of :mod:`hdpbsid.bases.spectra` and :func:`run_core`
  (normalisation, pseudo-input rows, the default past window and the PBSID core) of
  :mod:`hdpbsid.bases.basis_core`.

Pseudo-inputs: terms of the coefficient equation with a *known* coefficient row and an
*unknown* vector factor (the boundary terms ``x(t0) phi(t0)^T - x(tN) phi(tN)^T`` of a
record that does not start and end at rest, the truncation of the last column of a cut
derivative operator) are appended to the inputs; their ``B`` columns are estimated with
the rest and discarded.  They do not enter the output equation (``D = 0`` for them).
"""

from __future__ import annotations

import functools
import warnings
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

import slbasis
from hdpbsid.bases.basis_core import (
    COLS_PER_REGRESSOR,
    P_DEFAULT_RANGE,
    RIDGE_FLOOR,
    BasisTooSmall,
    CoreOut,
    best_hold,
    hold_criterion,
    run_core,
    window_criteria,
)
from hdpbsid.bases.basis_core import (
    _largest_determined_p as _largest_determined_p,
)
from hdpbsid.bases.memo import digest, memoize
from hdpbsid.bases.settings import INPUT_HOLDS, BasisSettings
from hdpbsid.bases.spectra import (
    BROADBAND_SHARE,
    ENERGY_FRACTION,
    FLOOR_MARGIN,
    SPECTRA_CACHE_SIZE,
    bandwidth,
    data_bandwidth,
    noise_floor,
    spectra_data_bandwidth,
    spectrum_bandwidth,
)
from hdpbsid.bases.spectra import (
    _power_spectra as _power_spectra,
)
from hdpbsid.core.varx import CachedPowers
from hdpbsid.data.checks import check_positive_int
from hdpbsid.models.model import StateSpaceModel
from hdpbsid.runtime import user_stacklevel

__all__ = [
    "ProjectionSettings",
    "PROJECTION",
    "BasisTooSmall",
    "SolveLag",
    "BlockShift",
    "bandwidth",
    "data_bandwidth",
    "spectrum_bandwidth",
    "spectra_data_bandwidth",
    "noise_floor",
    "clip_basis_size",
    "CoreOut",
    "run_core",
    "window_criteria",
    "INPUT_HOLDS",
    "project_record",
    "resolve_holds",
    "best_hold",
    "hold_criterion",
    "integrator_model",
    "shared_basis",
    "basis_values",
    "BASIS_CACHE_SIZE",
    "GAUSS_NODES",
    "PAIRING_ULPS",
    "ENERGY_FRACTION",
    "BROADBAND_SHARE",
    "FLOOR_MARGIN",
    "SPECTRA_CACHE_SIZE",
    "P_DEFAULT_RANGE",
    "COLS_PER_REGRESSOR",
    "RIDGE_FLOOR",
]

Array = NDArray[np.float64]
Mask = NDArray[np.bool_]


@dataclass(frozen=True)
class ProjectionSettings:
    """The constants of the projection and of the shared bases, each with its reason.

    Parameters
    ----------
    basis_cache_size : int, optional
        Bases (and boundary values) kept by :func:`shared_basis` / :func:`basis_values`.
    gauss_nodes : int, optional
        Gauss-Legendre nodes per sample interval in :func:`project_record`.
    pairing_ulps : int, optional
        Tolerance, in units in the last place of the largest time, of the mirrored
        nodes paired by the projection.

    Examples
    --------
    >>> ProjectionSettings().gauss_nodes
    3
    """

    #: bases (and their boundary values) kept by :func:`shared_basis` /
    #: :func:`basis_values`: an order or method sweep touches the estimation part and the
    #: whole record, a few operator scales and windows each
    basis_cache_size: int = 32
    #: Gauss-Legendre nodes per sample interval in :func:`project_record`: exact up to
    #: the variation of ``phi_n`` inside one interval, relative error ``~ (w h)^6``
    gauss_nodes: int = 3
    #: mirrored quadrature nodes are paired by the projection when they are symmetric
    #: about the basis centre to within this many units in the last place of the
    #: largest time: the rounding of the nodes themselves (``t_k + h (1 + xi) / 2``,
    #: ``t_k = k dt``)
    pairing_ulps: int = 8


#: the settings the projection uses
PROJECTION = ProjectionSettings()
#: the fields of :data:`PROJECTION` under their former names
BASIS_CACHE_SIZE = PROJECTION.basis_cache_size
GAUSS_NODES = PROJECTION.gauss_nodes
PAIRING_ULPS = PROJECTION.pairing_ulps


@functools.lru_cache(maxsize=PROJECTION.basis_cache_size)
def _basis(family: Any, N: int, span: tuple[float, float], params: tuple) -> Any:
    return slbasis.basis(family, N, span, **dict(params))


def shared_basis(family: Any, N: int, span: tuple[float, float], **params: Any) -> Any:
    """``slbasis.basis(family, N, span, **params)``, the same object for the same arguments.

    An order sweep fits one record at every order, and a basis costs its construction
    every time (the extreme nodes of the default time scale are an eigenvalue problem of
    size ``N``); a basis is not modified after construction, so the last
    :data:`BASIS_CACHE_SIZE` are kept.  Arguments that cannot be hashed (a user's
    Sturm-Liouville problem) are not cached.

    Parameters
    ----------
    family : str or object
        The family name (``"hermite"``, ``"legendre"``, ...) or problem
        (:func:`slbasis.basis`).
    N : int
        Number of functions.
    span : tuple of float
        The window ``(t0, t1)`` (s).
    **params
        Further arguments of :func:`slbasis.basis` (``scale``, family parameters).

    Returns
    -------
    Basis
        The basis.

    Examples
    --------
    >>> b = shared_basis("legendre", 8, (0.0, 2.0))
    >>> b is shared_basis("legendre", 8, (0.0, 2.0)), b.N
    (True, 8)
    """
    try:
        key = tuple(sorted(params.items()))
        hash((family, key))
    except TypeError:
        return slbasis.basis(family, N, span, **params)
    return _basis(family, int(N), (float(span[0]), float(span[1])), key)


@functools.lru_cache(maxsize=PROJECTION.basis_cache_size)
def basis_values(basis: Any, points: tuple[float, ...]) -> Array:
    """``basis.eval(points)``, read-only, kept per basis object.

    :func:`shared_basis` returns the same object for the same arguments, so the boundary
    rows of a record are evaluated once for all the orders of a sweep.

    Parameters
    ----------
    basis : Basis
        A (hashable) basis.
    points : tuple of float
        The times.

    Returns
    -------
    ndarray, shape (N, len(points))
        ``phi_n(points)``, not writeable.

    Examples
    --------
    >>> basis_values(shared_basis("legendre", 8, (0.0, 2.0)), (0.0, 2.0)).shape
    (8, 2)
    """
    out = np.asarray(basis.eval(np.array(points, dtype=float)))
    out.flags.writeable = False
    return out


class SolveLag(CachedPowers):
    """``apply(W, j) = W M^j`` with ``W M`` computed by a solve, never by a dense inverse.

    In the integrator form "one step back" is ``M = D'^{-1}``; applying it as a (banded)
    solve with ``D'^T`` is exact and ``O(N)`` per row for banded ``D'``, where forming the
    inverse would be dense and less accurate (Golub & Van Loan, sec. 3.1 and 4.3).  Every
    column is valid: the basis-domain equations hold on all columns once the boundary and
    truncation terms are pseudo-inputs.  The last argument's powers are cached, so
    ``past_blocks`` (``j = p, ..., 1``) costs ``p`` solves.

    Parameters
    ----------
    solve : callable
        Maps a ``(rows, N)`` array ``W`` to ``W M``.
    name : str, optional
        Name of ``M`` in ``repr`` and options.
    key : object, optional
        The arrays and numbers that define ``M`` exactly (e.g. the banded matrix solved
        with), returned by :meth:`cache_key` for the memoised core stages; None: not
        keyable.
    remember : int, optional
        How many one-step results ``W -> W M`` to keep, keyed by the contents of ``W`` (for
        a dense, costly ``M`` whose lag object is reused: the orders of a sweep lag the same
        rows to their ``p`` powers, each order one power further).

    Examples
    --------
    >>> lag = SolveLag(lambda W: W @ np.diag([0.5, 0.25]), "diag")
    >>> lag.apply(np.ones((1, 2)), 2)
    array([[0.25  , 0.0625]])
    """

    def __init__(
        self, solve: Callable[[Array], Array], name: str = "M", key: Any = None, remember: int = 0
    ) -> None:
        super().__init__()
        self._solve = solve
        self._name = name
        self._cache_key = key
        self._remember = int(remember)
        self._steps: OrderedDict[bytes, Array] = OrderedDict()

    def cache_key(self) -> Any:
        """What defines ``M`` exactly (:mod:`hdpbsid.bases.memo`), or None.

        Returns
        -------
        bytes or None
            A digest of ``key``, computed once (a dense ``M`` would otherwise be hashed at
            every call).
        """
        if self._cache_key is not None and not isinstance(self._cache_key, bytes):
            self._cache_key = digest(self._cache_key)
        return self._cache_key

    def _once(self, W: Array) -> Array:
        if not self._remember:
            return self._solve(W)
        k = digest(W)
        if k in self._steps:
            self._steps.move_to_end(k)
            return self._steps[k].copy()
        out = self._solve(W)
        self._steps[k] = out.copy()
        if len(self._steps) > self._remember:
            self._steps.popitem(last=False)
        return out

    def valid_columns(self, valid: Mask, j: int) -> Mask:
        # M mixes all columns: one unknown column spoils every lagged column
        """All columns when all are known, else none: ``M`` mixes all columns.

        Parameters
        ----------
        valid : ndarray of bool, shape (N,)
            The known input columns.
        j : int
            Number of lags.

        Returns
        -------
        ndarray of bool, shape (N,)
            ``valid`` when it is all True, else all False.
        """
        return valid.copy() if valid.all() else np.zeros_like(valid)

    def __repr__(self) -> str:
        return f"SolveLag({self._name})"


class BlockShift:
    """Sample shift inside consecutive blocks of ``block`` columns.

    Used by the Laguerre-filter variant, whose data are, for every sample time, a block of
    ``N`` filter outputs indexed by the Laguerre index.  Columns whose lag would reach into
    the previous block are invalid.

    Parameters
    ----------
    block : int
        Columns per block, ``>= 1``.

    Attributes
    ----------
    block : int
        Columns per block.

    Raises
    ------
    ValueError
        If ``block`` is not a positive integer.

    Examples
    --------
    >>> shift = BlockShift(3)
    >>> shift.apply(np.arange(6.0)[None], 1)
    array([[0., 0., 1., 0., 3., 4.]])
    >>> shift.valid_columns(np.ones(6, dtype=bool), 1)
    array([False,  True,  True, False,  True,  True])
    """

    def __init__(self, block: int) -> None:
        self.block = check_positive_int(block, "block")

    def cache_key(self) -> Any:
        """The block length defines the operator (:mod:`hdpbsid.bases.memo`).

        Returns
        -------
        int
            ``block``.
        """
        return self.block

    def apply(self, W: Array, j: int) -> Array:
        """``W`` shifted ``j`` columns back inside each block, zeros at the block starts.

        Parameters
        ----------
        W : ndarray, shape (rows, nb * block)
            Data matrix.
        j : int
            Number of lags.

        Returns
        -------
        ndarray, shape (rows, nb * block)
            The shifted matrix.
        """
        nb = W.shape[1] // self.block
        V = W.reshape(W.shape[0], nb, self.block)
        out = np.zeros_like(V)
        if j == 0:
            out[...] = V
        elif j < self.block:
            out[:, :, j:] = V[:, :, :-j]
        return out.reshape(W.shape)

    def valid_columns(self, valid: Mask, j: int) -> Mask:
        """The columns whose sample ``j`` back lies in the same block and is known.

        Parameters
        ----------
        valid : ndarray of bool, shape (nb * block,)
            The known input columns.
        j : int
            Number of lags.

        Returns
        -------
        ndarray of bool, shape (nb * block,)
            The determined output columns.
        """
        nb = valid.shape[0] // self.block
        V = valid.reshape(nb, self.block)
        out = np.zeros_like(V)
        if j == 0:
            out[...] = V
        elif j < self.block:
            out[:, j:] = V[:, :-j]
        return out.reshape(valid.shape)

    def __repr__(self) -> str:
        return f"BlockShift({self.block})"


def clip_basis_size(
    wanted: float, n_min: int, n_max: int, ns: int, method: str, rule: str
) -> tuple[int, str]:
    """Clip a default basis size to ``[n_min, n_max]`` and to ``Ns / 2``, warning when an
    upper limit binds.

    The default rules size the basis from the record length and bandwidth; ``Ns / 2`` is
    the most functions the samples resolve.  When the record is so long or broadband that
    the rule exceeds a limit, the basis covers less than the rule's band and accuracy
    suffers: the projection misses the part of the signals above the band the capped basis
    resolves, and the modes there are biased.  That is said with a ``RuntimeWarning``,
    never silently.

    Parameters
    ----------
    wanted : float
        The size the rule asks for.
    n_min : int
        Lower limit.
    n_max : int
        Upper limit (cost).
    ns : int
        Number of samples.
    method : str
        Method name for the warning.
    rule : str
        The rule's text, for the warning and the returned reason.

    Returns
    -------
    N : int
        The size.
    rule : str
        The rule, the limits and, when capped, what it asked for.

    Examples
    --------
    >>> clip_basis_size(150.4, 100, 4000, 1000, "hermite", "N = rule")
    (151, 'N = rule, clipped to [100, 4000] and <= Ns/2')
    """
    N = max(n_min, int(np.ceil(wanted)))
    limit, why = (n_max, "the default cap") if n_max <= ns // 2 else (ns // 2, "Ns/2")
    text = f"{rule}, clipped to [{n_min}, {n_max}] and <= Ns/2"
    if N > limit:
        warnings.warn(
            f"{method}: the basis-size rule ({rule}) asks for N = {N}, more than {why} "
            f"= {limit}; using N = {limit}, which covers a narrower band than the rule "
            f"wants. Pass N explicitly (and check the fit) or identify on a shorter window.",
            RuntimeWarning,
            stacklevel=user_stacklevel(),
        )
        N = limit
        text += f" (capped by {why}: the rule asked for {int(np.ceil(wanted))})"
    return N, text


@memoize
def project_record(
    basis: Any, t: Array, u: Array, y: Array, holds: tuple[str, ...] = ("foh",)
) -> tuple[list[Array], Array]:
    """Coefficient rows of the interpolants of the samples, integrated exactly.

    Sampled data define a continuous signal only together with an interpolation rule.  The
    outputs (states seen through ``C``) are continuous: they are interpolated linearly
    between samples.  The inputs follow ``holds`` (one projection per entry):

    * ``"zoh"``: ``u(t) = u_k`` on ``[t_k, t_{k+1})`` -- a digital controller's command,
      :func:`hdpbsid.systems.linear.simulate_zoh`; the last sample is not used;
    * ``"foh"``: linear between samples (``scipy.signal.lsim``'s default);
    * ``"trapezoid"``: the product ``phi_n u`` by the trapezoid rule on the samples (like
      ``"foh"`` up to ``O(h^2 |phi_n''|)``).

    ``int phi_n(t) s(t) dt`` is evaluated with :data:`GAUSS_NODES` Gauss-Legendre nodes per
    sample interval, exact up to the variation of ``phi_n`` inside one interval (local
    frequency ``w``: relative error ``~ (w h)^6``).  Trapezoid quadrature of the product
    instead errs by ``~ (w h)^2 / 12`` with ``w`` up to the basis band, and treating a held
    input as linear shifts it by half a sample, which biases fast and unstable modes.

    Parameters
    ----------
    basis : Basis
        The basis of the window.
    t : ndarray, shape (Ns,)
        Sample times (s), increasing.
    u : ndarray, shape (Ns, m)
        Inputs.
    y : ndarray, shape (Ns, l)
        Outputs.
    holds : tuple of str, optional
        Input holds to project, each one of ``"zoh"``, ``"foh"``, ``"trapezoid"``.

    Returns
    -------
    Us : list of ndarray, shape (m, N)
        The input rows, one per hold.
    Y : ndarray, shape (l, N)
        The output rows.

    Raises
    ------
    ValueError
        If a hold is not one of :data:`INPUT_HOLDS`.

    References
    ----------
    .. [1] G. H. Golub and J. H. Welsch, "Calculation of Gauss quadrature rules", *Math.
       Comp.* 23(106), 221-230, 1969.

    Examples
    --------
    ``y = t`` on ``[0, 2]``: the coefficients on the orthonormal Legendre functions are
    ``sqrt(2)`` and ``sqrt(3/2) * 2/3``:

    >>> basis = shared_basis("legendre", 8, (0.0, 2.0))
    >>> t = np.linspace(0.0, 2.0, 201)
    >>> Us, Y = project_record(basis, t, np.ones((201, 1)), t[:, None])
    >>> np.round(Y[0, :2], 6)
    array([1.414214, 0.816497])
    """
    g = PROJECTION.gauss_nodes
    x, w = np.polynomial.legendre.leggauss(g)
    h = np.diff(t)
    tn = (t[:-1, None] + h[:, None] * (1.0 + x[None, :]) / 2.0).ravel()
    wn = (h[:, None] * w[None, :] / 2.0).ravel()
    # linear interpolation weights of the nodes between samples k and k+1
    lam = np.tile((1.0 + x) / 2.0, t.size - 1)[:, None]

    def lin(s: Array) -> Array:
        return (1.0 - lam) * np.repeat(s[:-1], g, axis=0) + lam * np.repeat(s[1:], g, axis=0)

    m = u.shape[1]
    cols: list[Array] = []
    trap = []
    for hold in holds:
        if hold == "zoh":
            cols.append(np.repeat(u[:-1], g, axis=0))
        elif hold == "foh":
            cols.append(lin(u))
        elif hold == "trapezoid":
            trap.append(len(cols))
            cols.append(np.zeros((tn.size, m)))
        else:
            raise ValueError(f"input_hold must be one of {INPUT_HOLDS}, got {hold!r}")
    cols.append(lin(y))
    c = _project_nodes(basis, tn, wn, np.hstack(cols))
    Us = [c[i * m : (i + 1) * m] for i in range(len(holds))]
    for i in trap:
        Us[i] = basis.project(t, u).reshape(c.shape[1], -1).T if m else Us[i]
    return Us, c[len(holds) * m :]


def _has_parity(basis: Any) -> bool:
    """Whether ``phi_n(centre - s) = (-1)^n phi_n(centre + s)`` holds for the basis, exactly
    in floating point: the three-term recurrence has no diagonal (``b_n = 0``, so each step
    maps ``x -> -x`` to a sign flip, exact in IEEE arithmetic) and ``phi_0`` is even
    (Hermite functions, Legendre polynomials; not Laguerre functions)."""
    kernel = getattr(basis, "kernel", None)
    if kernel is None or not hasattr(kernel, "jacobi") or not hasattr(kernel, "log_phi0"):
        return False
    diag, _ = kernel.jacobi(basis.N)
    if np.any(np.asarray(diag) != 0):
        return False
    a, b = kernel.interval
    if not (np.isinf(a) and np.isinf(b)) and a != -b:
        return False
    xs = np.array([0.25, 0.5, 0.75]) * (1.0 if np.isfinite(b) else 4.0)
    la, sa = (np.asarray(v, dtype=float) for v in kernel.log_phi0(xs))
    lb, sb = (np.asarray(v, dtype=float) for v in kernel.log_phi0(-xs))
    return bool(np.array_equal(la, lb) and np.array_equal(sa, sb))


def _project_nodes(basis: Any, tn: Array, wn: Array, S: Array) -> Array:
    """``c[:, n] = sum_i wn_i S_i phi_n(tn_i)`` (coefficient rows, ``S``: nodes x signals).

    When the basis has parity about its centre (:func:`_has_parity`) and the nodes are
    mirror images about it to within :data:`PAIRING_ULPS` (a uniformly sampled record on
    its own basis), each pair ``(i, i')`` is evaluated once:
    ``phi_n(tn_i) wn_i S_i + phi_n(tn_i') wn_i' S_i' = phi_n(tn_i) (wn_i S_i +- wn_i' S_i')``
    with ``+`` for even ``n``, ``-`` for odd ``n``, so the recurrence runs over half the
    nodes with twice the signals.  The pair is evaluated at the mean of the two distances from the
    centre, i.e. each node moves by at most the pairing tolerance, the size of the
    rounding already in the nodes.  Each row sums only the combination its parity needs
    (``Basis.project_alternating``): half the multiply-adds of projecting both.
    """
    k = S.shape[1]
    n = tn.size
    half = n // 2
    tmap = getattr(basis, "tmap", None)
    c0 = float(tmap.centre) if tmap is not None else np.nan  # x = (t - c0) * scale
    tol = PROJECTION.pairing_ulps * np.finfo(float).eps * float(np.max(np.abs(tn))) if n else 0.0
    tau = tn - c0
    lo, hi = tau[:half][::-1], tau[n - half :]  # mirror partners, closest to the centre first
    paired = (
        half > 0
        and hasattr(basis, "project_alternating")
        and _has_parity(basis)
        and bool(np.all(np.abs(hi + lo) <= tol))
        and (n % 2 == 0 or abs(tau[half]) <= tol)
    )
    if not paired:
        c = basis.project(tn, S, weights=wn)
        return c.reshape(c.shape[0], -1).T
    wS = wn[:, None] * S
    w_hi, w_lo = wS[n - half :], wS[:half][::-1]
    plus, minus = w_hi + w_lo, w_hi - w_lo
    t_pair = c0 + 0.5 * (hi - lo)
    if n % 2:
        t_pair = np.concatenate([[c0], t_pair])
        plus = np.vstack([wS[half : half + 1], plus])
        minus = np.vstack([np.zeros((1, k)), minus])
    c = basis.project_alternating(t_pair, plus, minus, weights=np.ones(t_pair.size))
    return c.reshape(c.shape[0], -1).T


def resolve_holds(input_hold: Any, m: int) -> tuple[str, ...]:
    """The input holds to project for the setting ``input_hold``.

    Parameters
    ----------
    input_hold : str
        ``"auto"``, or one hold (validated by :class:`~hdpbsid.bases.settings.BasisSettings`).
    m : int
        Number of inputs (without inputs there is nothing to decide).

    Returns
    -------
    tuple of str
        ``("zoh", "foh")`` for ``"auto"`` with inputs, ``("foh",)`` without, else
        ``(input_hold,)``.

    Examples
    --------
    >>> resolve_holds("auto", 1), resolve_holds("zoh", 1)
    (('zoh', 'foh'), ('zoh',))
    """
    if input_hold == "auto":
        return ("zoh", "foh") if m else ("foh",)
    return (input_hold,)


def integrator_model(
    out: CoreOut,
    alpha: float,
    beta: float,
    gamma: float,
    options: dict[str, Any],
    *,
    settings: BasisSettings,
    hold: str,
    hold_criterion: dict[str, float],
    order: int | None,
) -> StateSpaceModel:
    r"""Continuous-time model from the basis-domain system of the integrator form.

    The core identified ``X D' = A' X + B' U + K' E`` with ``D' = (D / alpha + beta I) /
    gamma``; mapping back gives ``A = alpha (gamma A' - beta I)``, ``B = alpha gamma B'``,
    ``K = alpha gamma K'``, ``C, D`` unchanged.

    Parameters
    ----------
    out : CoreOut
        The core's basis-domain system.
    alpha : float
        Operator scale (rad/s).
    beta : float
        Shift of the integrator form.
    gamma : float
        Gain of the integrator form.
    options : dict
        Method-specific options, merged with the core's and the shared ones (operator
        parameters, input hold, ``A'``).
    settings : BasisSettings
        The method's settings.
    hold : str
        The input hold used.
    hold_criterion : dict of str to float
        The criterion of each hold tried.
    order : int or None
        The order asked for (None: selected, ``max_order`` recorded).

    Returns
    -------
    StateSpaceModel
        The continuous-time model.

    Notes
    -----
    .. math::

        D' = \frac{D/\alpha + \beta I}{\gamma}, \quad
        A = \alpha(\gamma A' - \beta I), \quad B = \alpha\gamma B', \quad K = \alpha\gamma K' .

    An eigenvalue :math:`\lambda` of ``A`` maps to :math:`(\lambda/\alpha + \beta)/\gamma`.
    """
    n = out.A.shape[0]
    merged = dict(out.options)
    merged.update(
        {
            "alpha": alpha,
            "beta": beta,
            "gamma": gamma,
            "input_hold": hold,
            "input_hold_rule": (
                "given"
                if settings.input_hold != "auto"
                else "auto: zoh and foh judged by the AIC of the VARX fit, the smaller kept"
            ),
            "input_hold_criterion": hold_criterion,
            "projection": "exact integral of the sample interpolants (Gauss nodes)",
            "A_prime": out.A,
        }
    )
    merged.update(options)
    if order is None:
        merged["max_order"] = settings.max_order
    return StateSpaceModel(
        alpha * (gamma * out.A - beta * np.eye(n)),
        alpha * gamma * out.B,
        out.C,
        out.D,
        alpha * gamma * out.K,
        singular_values=out.core.singular_values,
        options=merged,
        noise_covariance=out.noise_covariance,
    )
