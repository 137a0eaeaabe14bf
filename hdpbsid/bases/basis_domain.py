"""Shared machinery of the basis-domain methods (HD-PBSID, CT-PBSID, Legendre PBSID).

The same PBSID core in a basis domain (docs/theory.md): the record is projected onto ``N``
orthonormal functions, signals become coefficient rows (rows = signals, columns = basis
index) and "one sample back" becomes a linear operator ``M`` on those rows.  This module
holds what the methods share:

* :class:`SolveLag` -- a :class:`~hdpbsid.core.varx.LagOperator` ``W -> W M^j`` where ``M`` is
  applied by a (banded) solve, never formed as a dense inverse;
* :class:`BlockShift` -- the sample shift inside blocks of columns (Laguerre filters);
* :func:`bandwidth` -- the data bandwidth used by the default rules;
* :func:`run_core` -- normalisation, pseudo-input rows (boundary and truncation terms),
  the default past window and the PBSID core (:func:`hdpbsid.core.pbsid.pbsid_core`).

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
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

import slbasis
from hdpbsid.bases.memo import digest, memoize, past_window_aic, varx_stage
from hdpbsid.bases.settings import INPUT_HOLDS, BasisSettings
from hdpbsid.core.blocks import BlockLag, BlockPseudo, best_window, pbsid_core_blocks
from hdpbsid.core.pbsid import CoreResult
from hdpbsid.core.varx import CachedPowers
from hdpbsid.data.checks import check_positive_int
from hdpbsid.models.model import StateSpaceModel
from hdpbsid.runtime import user_stacklevel

__all__ = [
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
    "INPUT_HOLDS",
    "project_record",
    "resolve_holds",
    "best_hold",
    "hold_criterion",
    "integrator_model",
    "shared_basis",
    "basis_values",
]

Array = NDArray[np.float64]
Mask = NDArray[np.bool_]

#: bases (and their boundary values) kept by :func:`shared_basis` / :func:`basis_values`:
#: an order or method sweep touches the estimation part and the whole record, a few
#: operator scales and windows each
BASIS_CACHE_SIZE = 32


@functools.lru_cache(maxsize=BASIS_CACHE_SIZE)
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


@functools.lru_cache(maxsize=BASIS_CACHE_SIZE)
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


#: fraction of the (detrended) signal energy below the bandwidth estimate
ENERGY_FRACTION = 0.99
#: noise-floor share above which an input column counts as broadband (data_bandwidth)
#: (a band-limited input's floor carries a few per cent of its power, a white one's all of
#: it; a closed-loop command dominated by fed-back sensor noise lies in between, above
#: this share)
BROADBAND_SHARE = 0.25
#: bandwidth() counts only power above FLOOR_MARGIN times the noise floor: periodogram
#: bins of white noise are exponentially distributed, so their excursions above the floor
#: itself add up over thousands of bins (on a noisy record enough to move a 95 % band to
#: Nyquist); above 3 floors the expected excess is e^-3 = 5 % of the noise
FLOOR_MARGIN = 3.0
#: default past windows tried by the AIC rule.  Every lag adds ``m + q + l`` regressors
#: per output; over a wider range (up to 6) AIC chose windows of 5-6 on closed-loop
#: records, where the basis-domain VARX was poorly determined and the models spread more
#: (the Laguerre projection broke down at high SNR), while open-loop records are as
#: accurate with 2..4
P_DEFAULT_RANGE = (2, 4)
#: basis-domain "samples" per VARX regressor and output kept by the default p rule
COLS_PER_REGRESSOR = 6
#: lower bound of the GCV ridge parameter relative to the largest singular value of the
#: VARX regressors: projected data are exact only to the quadrature/interpolation
#: precision (~1e-5..1e-4 relative), and on noise-free closed-loop data GCV picks 0,
#: letting near-collinear regressors (u ~ controller(y)) blow the VARX up; a floor
#: below that precision costs no accuracy and keeps those directions damped
RIDGE_FLOOR = 1e-6
#: Gauss-Legendre nodes per sample interval in :func:`project_record`
GAUSS_NODES = 3


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


def _power_spectra(t: Array, x: Array) -> tuple[Array, Array]:
    """Angular frequencies and Hann-windowed periodograms of the detrended columns of
    ``x`` (resampled linearly onto a uniform grid with the mean step)."""
    ns = t.shape[0]
    tu = np.linspace(t[0], t[-1], ns)
    dt = (t[-1] - t[0]) / (ns - 1)
    P = np.empty((ns // 2 + 1, x.shape[1]))
    for k in range(x.shape[1]):
        xk = np.interp(tu, t, x[:, k])
        xk = xk - np.polyval(np.polyfit(tu - tu[0], xk, 1), tu - tu[0])
        P[:, k] = np.abs(np.fft.rfft(xk * np.hanning(ns))) ** 2
    return 2 * np.pi * np.fft.rfftfreq(ns, dt), P


#: Periodograms kept by :func:`_record_spectra`: one identification asks for the
#: spectra of a record's inputs and outputs several times (the data bandwidth, the
#: default window, the band of the operator scale) and its held-out check those of
#: the sub-record
SPECTRA_CACHE_SIZE = 8


@memoize(size=SPECTRA_CACHE_SIZE)
def _record_spectra(t: Array, x: Array) -> tuple[Array, Array]:
    """:func:`_power_spectra`, memoised by the contents of ``t`` and ``x``
    (:mod:`hdpbsid.bases.memo`; the arrays returned are read-only)."""
    return _power_spectra(t, x)


def noise_floor(P: Array) -> tuple[float, float]:
    """White-noise floor of a periodogram and its share of the total power.

    The floor is estimated from the upper half of the spectrum (a band-limited signal
    sampled well above its band leaves only white measurement noise there) as its median
    divided by ``ln 2``: periodogram bins of white noise are exponentially distributed, with
    median ``ln 2`` times the mean, and the median ignores isolated peaks.

    Parameters
    ----------
    P : ndarray, shape (bins,)
        A periodogram.

    Returns
    -------
    floor : float
        The floor (mean power of a white bin).
    share : float
        ``floor * len(P) / sum(P)``; near 1 the column is white (or noise-dominated) over
        the whole band.

    References
    ----------
    .. [1] P. Stoica and R. Moses, *Spectral Analysis of Signals*, Prentice Hall, 2005,
       sec. 2.4 (the periodogram's distribution).

    Examples
    --------
    >>> P = np.random.default_rng(0).exponential(2.0, 1000)  # white, mean 2
    >>> np.round(noise_floor(P), 2)
    array([1.93, 0.95])
    """
    total = float(P.sum())
    if total == 0.0:
        return 0.0, 0.0
    floor = float(np.median(P[P.size // 2 :])) / np.log(2.0)
    return floor, floor * P.size / total


def bandwidth(
    t: Array, x: Array, fraction: float = ENERGY_FRACTION, subtract_floor: bool = True
) -> float:
    """Angular frequency (rad/s) below which ``fraction`` of the energy of ``x`` lies.

    Each column is detrended (mean and linear trend removed, so a record that does not
    start and end at rest does not look broadband), Hann-windowed (the jump between the
    ends would otherwise leak energy to high frequencies) and resampled linearly onto a
    uniform grid with the mean step (non-uniform ``t``).  With ``subtract_floor`` the
    power up to :data:`FLOOR_MARGIN` times the white-noise floor (:func:`noise_floor`) is
    removed first, so measurement noise does not stretch the band to Nyquist; a column with
    no power above it keeps its raw spectrum.

    Parameters
    ----------
    t : ndarray, shape (Ns,)
        Sample times (s), increasing.
    x : ndarray, shape (Ns, k)
        The signals, one per column.
    fraction : float, optional
        Energy fraction, in ``(0, 1)``.
    subtract_floor : bool, optional
        Remove the noise floor first.

    Returns
    -------
    float
        The largest band over the columns (rad/s).

    Examples
    --------
    >>> t = np.linspace(0.0, 100.0, 10001)
    >>> round(bandwidth(t, np.sin(2.0 * t)[:, None]), 2)  # a sine at 2 rad/s
    2.07
    """
    return spectrum_bandwidth(*_record_spectra(t, x), fraction, subtract_floor)


def spectrum_bandwidth(
    w: Array, P: Array, fraction: float = ENERGY_FRACTION, subtract_floor: bool = True
) -> float:
    """:func:`bandwidth` from given power spectra.

    Parameters
    ----------
    w : ndarray, shape (bins,)
        Angular frequencies (rad/s).
    P : ndarray, shape (bins, k)
        Power spectra, one per column (e.g. periodograms averaged over the chunks of a
        record read from disk).
    fraction : float, optional
        Energy fraction.
    subtract_floor : bool, optional
        Remove the noise floor first.

    Returns
    -------
    float
        The largest band over the columns (rad/s); 0 when every column is zero.
    """
    best = 0.0
    for k in range(P.shape[1]):
        Pk = P[:, k]
        if Pk.sum() == 0:
            continue
        if subtract_floor:
            excess = np.clip(Pk - FLOOR_MARGIN * noise_floor(Pk)[0], 0.0, None)
            Pk = excess if excess.sum() > 0 else Pk
        c = np.cumsum(Pk) / Pk.sum()
        i = int(np.searchsorted(c, fraction))
        best = max(best, float(w[min(i, w.size - 1)]))
    return best


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
def data_bandwidth(t: Array, u: Array, y: Array) -> float:
    """Bandwidth of a record: 95 % of each output's energy above its noise floor, and 99 %
    of each band-limited input's.

    :func:`bandwidth` removes the white-noise floor.  An input whose floor carries more
    than :data:`BROADBAND_SHARE` of its power is not band-limited at this sampling rate (a
    white excitation, or a closed-loop command dominated by fed-back sensor noise, shaped by
    the controller so that no flat floor removes it) and does not set the band: the outputs,
    low-passed by the plant, do.  The outputs get the lower fraction because their noise is
    never fully removed by a floor estimate.

    Parameters
    ----------
    t : ndarray, shape (Ns,)
        Sample times (s).
    u : ndarray, shape (Ns, m)
        Inputs.
    y : ndarray, shape (Ns, l)
        Outputs.

    Returns
    -------
    float
        The band (rad/s).

    Examples
    --------
    >>> t = np.linspace(0.0, 100.0, 10001)
    >>> s = np.sin(2.0 * t)[:, None]
    >>> round(data_bandwidth(t, s, s), 2)
    2.07
    """
    wu, Pu = _record_spectra(t, u)
    return spectra_data_bandwidth(wu, Pu, *_record_spectra(t, y))


def spectra_data_bandwidth(wu: Array, Pu: Array, wy: Array, Py: Array) -> float:
    """:func:`data_bandwidth` from the power spectra of the inputs and outputs.

    Parameters
    ----------
    wu : ndarray, shape (bins_u,)
        Angular frequencies of ``Pu`` (rad/s).
    Pu : ndarray, shape (bins_u, m)
        Input power spectra.
    wy : ndarray, shape (bins_y,)
        Angular frequencies of ``Py``.
    Py : ndarray, shape (bins_y, l)
        Output power spectra.

    Returns
    -------
    float
        The band (rad/s).
    """
    limited = [k for k in range(Pu.shape[1]) if noise_floor(Pu[:, k])[1] < BROADBAND_SHARE]
    band_u = spectrum_bandwidth(wu, Pu[:, limited], 0.99) if limited else 0.0
    return max(band_u, spectrum_bandwidth(wy, Py, 0.95))


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
    x, w = np.polynomial.legendre.leggauss(GAUSS_NODES)
    h = np.diff(t)
    g = GAUSS_NODES
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


#: mirrored quadrature nodes are paired by :func:`_project_nodes` when they are symmetric
#: about the basis centre to within this many units in the last place of the largest
#: time: the rounding of the nodes themselves (``t_k + h (1 + xi) / 2``, ``t_k = k dt``)
PAIRING_ULPS = 8


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
    tol = PAIRING_ULPS * np.finfo(float).eps * float(np.max(np.abs(tn))) if n else 0.0
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


def window_criteria(
    sc: _Scaled,
    lag: BlockLag,
    P: Sequence[Array] | None,
    feedthrough: bool,
    p_range: tuple[int, int] | None,
    hi: int,
) -> Array:
    """AIC of the VARX fit for every past window from the lower end of the preferred
    range (``p_range``, default :data:`P_DEFAULT_RANGE`) to ``hi``, on the scaled rows
    ``sc`` (:func:`hdpbsid.core.blocks.select_past_window_blocks`, memoised: one
    computation for every order of a sweep and for the input-hold decision); ``inf``
    below the range."""
    lo = (p_range if p_range is not None else P_DEFAULT_RANGE)[0]
    _, crit = past_window_aic(sc.Uz, sc.Yz, hi, min(lo, hi), lag, P, feedthrough)
    return np.asarray(crit)


def hold_criterion(
    U: Array,
    Y: Array,
    P: Sequence[Array] | None,
    lag: BlockLag,
    *,
    p: int | None = None,
    p_range: tuple[int, int] | None = None,
    feedthrough: bool = False,
    normalize: bool = True,
    **_: Any,
) -> float:
    """The input-hold criterion of the input rows ``U``: the smallest AIC of the VARX fit.

    The VARX of ``Y`` on the past of ``U, Y`` (pseudo-input rows ``P`` eliminated) over the
    past windows of the default rule (:func:`run_core`: the preferred range capped at ``p
    (m + q + l) <= N / 6``), or at the given ``p``.  ``AIC = N log det Sigma + 2 l d``
    compares the holds directly: both projections regress the same output rows with the
    same number of coefficients, so at each window the AIC difference is ``N`` times the
    log-ratio of the innovation determinants, and the minimum over the windows chooses the
    hold and the window jointly.  The VARX is the order-free first step of the core, so the
    decision does not depend on the order (the hold is a property of the record), and every
    order of a sweep shares it.

    Parameters
    ----------
    U : ndarray, shape (m, N)
        Input rows of one hold.
    Y : ndarray, shape (l, N)
        Output rows.
    P : sequence of ndarray or None
        Pseudo-input rows per block.
    lag : BlockLag
        The block lag.
    p : int, optional
        A given past window.
    p_range : tuple of int, optional
        The preferred range (default :data:`P_DEFAULT_RANGE`).
    feedthrough : bool, optional
        Include ``D u_k``.
    normalize : bool, optional
        Scale the rows to unit RMS.
    _ : any
        Other core options, ignored (the caller passes them all).

    Returns
    -------
    float
        The criterion; ``inf`` when no window fits.

    References
    ----------
    .. [1] H. Akaike, "A new look at the statistical model identification", *IEEE Trans.
       Automatic Control* 19(6), 716-723, 1974.
    """
    sc = _scaled(U, Y, P, lag, normalize)
    if p is not None:
        lo = hi = p
        if p * sc.d >= sc.nb - p:
            return float("inf")
    else:
        lo, hi = p_range if p_range is not None else P_DEFAULT_RANGE
        hi = min(hi, sc.p_cap)
        if hi < max(lo, 1):
            return float("inf")
    _, crit = past_window_aic(sc.Uz, sc.Yz, hi, lo, lag, P, feedthrough)
    crit = np.asarray(crit)[lo - 1 : hi]
    return float(np.min(crit)) if crit.size else float("inf")


def best_hold(
    holds: tuple[str, ...],
    Us: list[Array],
    Y: Array,
    P: Sequence[Array] | None,
    lag: BlockLag,
    hold_range: tuple[int, int] | None = None,
    **core_options: Any,
) -> tuple[CoreOut, str, dict[str, float]]:
    """:func:`run_core` on the input projection with the smallest :func:`hold_criterion`.

    The wrong hold leaves a deterministic misfit in the innovations (on noise-free data the
    right one wins by orders of magnitude), so the AIC of the order-free VARX fit tells the
    holds apart; a tie keeps the first hold listed.  One core run per call whatever the
    number of holds.

    Parameters
    ----------
    holds : tuple of str
        The holds projected.
    Us : list of ndarray, shape (m, N)
        The input rows, one per hold.
    Y : ndarray, shape (l, N)
        Output rows.
    P : sequence of ndarray or None
        Pseudo-input rows per block.
    lag : BlockLag
        The block lag.
    hold_range : tuple of int, optional
        The past windows the criterion compares over when they are not the core's
        ``p_range`` (a method whose window follows the order passes its order-free one).
    **core_options
        Keyword arguments of :func:`run_core`.

    Returns
    -------
    out : CoreOut
        The core's result on the hold chosen.
    hold : str
        The hold.
    criterion : dict of str to float
        The criterion of each hold (empty when only one was projected).
    """
    crit: dict[str, float] = {}
    if len(holds) > 1:
        judged = {**core_options, "p_range": hold_range or core_options.get("p_range")}
        crit = {h: hold_criterion(U, Y, P, lag, **judged) for h, U in zip(holds, Us, strict=True)}
    hold = min(holds, key=lambda h: (crit.get(h, 0.0), holds.index(h)))
    return run_core(Us[holds.index(hold)], Y, P, lag, **core_options), hold, crit


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


def _rms_rows(W: Array, name: str) -> Array:
    r = np.sqrt(np.mean(W**2, axis=1))
    if np.any(r == 0):
        k = int(np.flatnonzero(r == 0)[0])
        raise ValueError(f"{name}[:, {k}] is identically zero: nothing to identify from it")
    return r


class BasisTooSmall(ValueError):
    """The default past-window rule cannot give the requested order a window.

    The order needs ``p >= p_needed`` (``f l >= n`` rows of ``Gamma L``), the precision
    rule ``p (m + q + l) <= N / 6`` allows less; the VARX is still determined up to
    ``p_max``.  A caller that must answer at that order (the user asked for it) may pass
    ``p=p_needed`` when ``p_needed <= p_max``: a less precise model, not none.

    Parameters
    ----------
    message : str
        The error message.
    p_needed : int
        The smallest window the order needs.
    p_max : int
        The largest window for which the VARX is determined.

    Attributes
    ----------
    p_needed : int
        As above.
    p_max : int
        As above.
    """

    def __init__(self, message: str, p_needed: int, p_max: int) -> None:
        super().__init__(message)
        self.p_needed, self.p_max = p_needed, p_max


@dataclass
class CoreOut:
    """Core result in the basis domain, scaled back to the user's units.

    Attributes
    ----------
    A : ndarray, shape (n, n)
        The index-domain ``A'``.
    B : ndarray, shape (n, m)
        Input matrix of the real inputs (user units).
    C : ndarray, shape (l, n)
        Output matrix (user units).
    D : ndarray, shape (l, m)
        Feedthrough (user units).
    K : ndarray, shape (n, l)
        Predictor gain (user units).
    B_pseudo : ndarray, shape (n, 0)
        Empty: the pseudo-inputs' coefficients differ per block and are eliminated, not
        reported.
    noise_covariance : ndarray, shape (l, l)
        Innovation covariance (user units).
    core : CoreResult
        The core's own result (normalised units).
    options : dict
        The core's options and the window rules.
    """

    A: Array
    B: Array
    C: Array
    D: Array
    K: Array
    B_pseudo: Array
    noise_covariance: Array
    core: CoreResult
    options: dict


def _largest_determined_p(nb: int, d: int, ncols: int, z: int) -> int:
    """Largest past window ``p`` for which the VARX least squares is determined: in the
    tightest block of ``nb`` columns, ``p d`` regressors (``d = m + q + l``) and ``p``
    columns lost to the lags leave more equations than unknowns, ``p d < nb - p``; over
    all ``ncols`` columns, ``p z < ncols - p`` (``z = m + l``)."""
    return int(max(0, min((nb - 1) // (d + 1), (ncols - 1) // (z + 1))))


@dataclass
class _Scaled:
    """The core's rows scaled to unit RMS (``normalize``) and the sizes of the tightest
    block: ``nb`` columns for ``d = m + q_b + l`` regressor rows per lag, ``p_cap`` the
    largest past window of the default rule ``p d <= nb / 6`` (:func:`run_core`)."""

    Uz: Array
    Yz: Array
    su: Array
    sy: Array
    pseudo: BlockPseudo | None
    qs: list[int]
    nb: int
    d: int
    worst: int
    p_cap: int


def _scaled(
    U: Array, Y: Array, P: Sequence[Array] | None, lag: BlockLag, normalize: bool
) -> _Scaled:
    m, l = U.shape[0], Y.shape[0]
    su = _rms_rows(U, "u") if (normalize and m) else np.ones(m)
    sy = _rms_rows(Y, "y") if normalize else np.ones(l)
    pseudo = BlockPseudo(lag, P) if P is not None else None
    qs = [0] * len(lag.sizes)
    if pseudo is not None:
        for _, _, bs, _, Pn in pseudo.groups:
            for b in bs:
                qs[b] = Pn.shape[0]
    # the tightest block: fewest columns per (m + q_b + l) regressor rows
    worst = int(np.argmin([n / (m + q + l) for n, q in zip(lag.sizes, qs, strict=True)]))
    nb, d = lag.sizes[worst], m + qs[worst] + l
    ncols = Y.shape[1]
    p_cap = min(nb // (COLS_PER_REGRESSOR * d), ncols // (COLS_PER_REGRESSOR * (m + l)))
    return _Scaled(U / su[:, None], Y / sy[:, None], su, sy, pseudo, qs, nb, d, worst, p_cap)


def run_core(
    U: Array,
    Y: Array,
    P: Sequence[Array] | None,
    lag: BlockLag,
    *,
    order: int | None,
    p: int | None,
    f: int | None,
    max_order: int,
    regularize: bool | str | float | None,
    feedthrough: bool,
    stable_k: bool,
    normalize: bool,
    p_range: tuple[int, int] | None = None,
    ridge_floor: float | None = None,
    instruments: Array | None = None,
) -> CoreOut:
    """Run the PBSID core on the coefficient rows of all blocks.

    The pseudo-inputs' factors are unknown and different in every block; they are
    eliminated from every least-squares step block by block
    (:func:`hdpbsid.core.blocks.pbsid_core_blocks`), so the regression keeps the size of
    one record's whatever the number of blocks.  Defaults: ``p`` minimises the AIC of the
    VARX fit (:func:`hdpbsid.core.blocks.select_past_window_blocks`) over ``p_range``
    (default :data:`P_DEFAULT_RANGE`), capped so that ``p (m + q_b + l) <= N_b / 6`` in
    every block; ``f = p``.

    Which limit is real: the preferred range's upper end is a variance choice, so an order
    that needs ``f l >= n`` rows of ``Gamma L`` beyond it gets ``p = ceil(n / l)``.
    ``N_b / 6`` is a precision rule (the VARX variance grows like ``1 / (N_b - p d)``) and
    stays for the default ``p``: lifting it lets held-out order selection pick orders the
    short records cannot support.  The mathematical limit is that the VARX be determined,
    ``p d < N_b - p``: an explicit ``p`` may go up to it, and the error for a default ``p``
    says so (:class:`BasisTooSmall`).

    Parameters
    ----------
    U : ndarray, shape (m, N)
        Input rows of all blocks side by side.
    Y : ndarray, shape (l, N)
        Output rows.
    P : sequence of ndarray or None
        ``P[b]`` the pseudo-input rows (``q_b x N_b``) of block ``b``.
    lag : BlockLag
        The block-diagonal lag.
    order : int or None
        Model order; None selects it.
    p : int or None
        Past window; None by the rule above.
    f : int or None
        Future window; None: ``f = p``.
    max_order : int
        Largest order of the selection.
    regularize : bool, str, float or None
        VARX regularisation (:func:`hdpbsid.core.varx.varx`).
    feedthrough : bool
        Estimate ``D``.
    stable_k : bool
        Riccati gain in place of the least-squares one.
    normalize : bool
        Scale the rows to unit RMS.
    p_range : tuple of int, optional
        The preferred range of the default window.
    ridge_floor : float, optional
        Lower bound of the GCV ridge (default :data:`RIDGE_FLOOR`: projected data are exact
        only to the quadrature precision).
    instruments : ndarray, optional
        Instrument rows on the ``N`` columns: the instrumental-variable core
        (:mod:`hdpbsid.methods.hermite_iv`).

    Returns
    -------
    CoreOut
        The basis-domain system in user units.

    Raises
    ------
    ValueError
        If an explicit ``p`` does not fit the basis, ``f`` is inconsistent with ``p`` or
        the order, order selection has fewer than 2 rows of ``Gamma L``, or a row is
        identically zero.
    BasisTooSmall
        If the default rule cannot give the order a window (a ``ValueError``).
    """
    m, l = U.shape[0], Y.shape[0]
    ncols = Y.shape[1]
    need = order if order is not None else 3
    f_min = -(-need // l)
    sc = _scaled(U, Y, P, lag, normalize)
    Uz, Yz, su, sy, pseudo = sc.Uz, sc.Yz, sc.su, sc.sy, sc.pseudo
    nb, d, worst, p_cap = sc.nb, sc.d, sc.worst, sc.p_cap
    qs = sc.qs
    crit = None
    if p is not None:
        if p * d >= nb - p:
            raise ValueError(
                f"p={p} is too large for the basis: the VARX has p*(m+q+l) = {p}*{d} = "
                f"{p * d} regressors per output (q = {qs[worst]} boundary/truncation rows) but "
                f"only {nb} basis coefficients in block {worst}; reduce p or increase N"
            )
        if f is None and p * l < need:
            raise ValueError(
                f"order {order if order is not None else 'selection'} needs f*l >= {need}, "
                f"but f = p = {p}; increase p"
            )
        p_rule = "given"
    else:
        lo, hi = p_range if p_range is not None else P_DEFAULT_RANGE
        lo = max(lo, f_min, f or 1)
        hi = min(hi, p_cap)
        if hi < lo:
            if lo > p_cap:
                p_max = _largest_determined_p(nb, d, ncols, m + l)
                raise BasisTooSmall(
                    f"the basis is too small for the requested order by the default rule: "
                    f"it needs a past window p >= {lo}, but N = {nb} coefficients and "
                    f"m+q+l = {d} rows give p <= {p_cap} by p*(m+q+l) <= "
                    f"N/{COLS_PER_REGRESSOR}; the VARX is determined up to p = {p_max} "
                    f"(p*(m+q+l) < N - p): pass p explicitly (less precise), increase N, or "
                    f"ask for a smaller order",
                    lo,
                    p_max,
                )
            # the order needs more rows of Gamma L (f*l >= n) than the preferred range
            # gives: the smallest window that shows it
            p = lo
            p_rule = (
                f"p = {lo}, the smallest window with f*l >= the order (above the preferred "
                f"range {P_DEFAULT_RANGE if p_range is None else p_range}; "
                f"p*(m+q+l) <= N/{COLS_PER_REGRESSOR})"
            )
        else:
            if hi > lo:
                # the criterion of every window of the range, shared by all orders and by
                # the input-hold decision (hold_criterion); this order may use p >= lo
                crit = window_criteria(sc, lag, P, feedthrough, p_range, hi)
                crit = np.where(np.arange(1, hi + 1) >= lo, crit, np.inf)
                p = best_window(crit, lo, hi, ncols)
            else:
                p = lo
            p_rule = (
                f"min AIC of the VARX fit over p in [{lo}, {hi}] "
                f"(p*(m+q+l) <= N/{COLS_PER_REGRESSOR}, f*l >= required rows)"
            )
    if f is not None and f > p:
        raise ValueError(f"the future window f must satisfy f <= p, got f={f} > p={p}")
    if f is not None and f * l < need:
        raise ValueError(f"order needs f*l >= {need}, but f*l = {f * l}; increase f")
    f_used = p if f is None else f
    mo = min(max_order, f_used * l - 1) if order is None else None
    if mo is not None and mo < 1:
        raise ValueError("order selection needs f*l >= 2; increase p/f or pass an order")
    # the order-independent VARX and SVD, shared by the orders of a sweep (memo.py)
    rf = RIDGE_FLOOR if ridge_floor is None else ridge_floor
    stage = varx_stage(Uz, Yz, p, lag, P, f_used, feedthrough, regularize, rf, instruments)
    core = pbsid_core_blocks(
        Uz,
        Yz,
        p,
        lag,
        pseudo,
        stage=stage,
        f=f_used,
        order=order,
        feedthrough=feedthrough,
        regularize=regularize,
        stable_k=stable_k,
        max_order=mo,
        ridge_floor=RIDGE_FLOOR if ridge_floor is None else ridge_floor,
        instruments=instruments,
    )
    B = core.B[:, :m] / su[None, :] if m else core.B[:, :0]
    C = core.C * sy[:, None]
    D = (sy[:, None] * core.D[:, :m] / su[None, :]) if m else core.D[:, :0]
    K = core.K / sy[None, :]
    ncov = sy[:, None] * core.noise_covariance * sy[None, :]
    opts: dict[str, Any] = dict(core.options)
    opts.update(
        {
            "normalize": normalize,
            "input_scale": su,
            "output_scale": sy,
            "p_rule": p_rule,
            "p_criterion_values": crit,
            "f_rule": "given" if f is not None else "f = p",
            "n_pseudo_inputs": pseudo.count if pseudo is not None else 0,
            "n_blocks": len(lag.sizes),
        }
    )
    return CoreOut(core.A, B, C, D, K, np.zeros((core.A.shape[0], 0)), ncov, core, opts)
