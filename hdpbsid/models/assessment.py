"""Model assessment on a record: fit of simulations / predictions and residual tests.

The statistics here work on arrays (prediction errors, inputs); the models produce those
arrays (:meth:`hdpbsid.StateSpaceModel.compare` and
:meth:`~hdpbsid.StateSpaceModel.residuals` call into this module, which imports nothing
from :mod:`hdpbsid.models.model`).

**Residual analysis** follows Ljung, *System Identification: Theory for the User*, 2nd
ed. (1999), sec. 16.6, as MATLAB's ``resid`` does.  For the one-step prediction errors
``e(t)`` of a model on ``N`` samples and an input ``u(t)``:

* *whiteness*: the normalised autocorrelation ``r_e(tau) = R_e(tau) / R_e(0)``,
  ``R_e(tau) = (1/N) sum_t e(t) e(t - tau)``, for ``tau = 1..M``.  For white ``e`` each
  ``sqrt(N) r_e(tau)`` is asymptotically standard normal, so 99 % of the lags fall within
  ``+-2.58 / sqrt(N)``; the portmanteau statistic of Ljung and Box (1978)
  ``Q = N (N + 2) sum_{tau=1}^{M} r_e(tau)^2 / (N - tau)`` is asymptotically
  ``chi^2(M)``, and whiteness is rejected at the 1 % level when ``Q`` exceeds its 99 %
  quantile.  The residuals' mean is *not* removed: a constant error (a wrong operating
  point) is a model defect and should show.
* *independence of the input*: ``r_eu(tau) = R_eu(tau) / sqrt(R_e(0) R_u(0))``,
  ``R_eu(tau) = (1/N) sum_t e(t) u(t - tau)``, ``tau = -M..M`` (``u`` with its own mean
  removed: a level carries no information about the dynamics).  Ljung's eq. (16.59):
  ``sqrt(N) r_eu(tau)`` is asymptotically normal with variance
  ``P = sum_k r_e(k) r_u(k)`` (``= 1`` for white ``e``), giving the band
  ``+-2.58 sqrt(P / N)``; jointly, ``zeta = N r^T P^{-1} r`` over the ``2M + 1`` lags
  (``P_ij = sum_k r_e(k) r_u(k + tau_i - tau_j)``, the sums truncated at ``|k| <= M``) is
  asymptotically ``chi^2(2M + 1)`` (Ljung eq. 16.61-16.62).  Directions of ``P`` with
  eigenvalues below ``1e-10`` of the largest (an input without excitation at those lags)
  are dropped and the degrees of freedom reduced accordingly.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hdpbsid.data.checks import scale_exponents

__all__ = [
    "AssessmentSettings",
    "ASSESSMENT",
    "Comparison",
    "ResidualReport",
    "fit_percent",
    "residual_tests",
    "correlation",
    "CONFIDENCE",
]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class AssessmentSettings:
    """The level of the residual tests.

    Attributes
    ----------
    confidence : float
        Confidence level of the bands and tests.
    """

    #: Confidence level of the bands and tests (MATLAB ``resid`` draws 99 % bands).
    confidence: float = 0.99


#: The settings in force.
ASSESSMENT = AssessmentSettings()
#: :attr:`AssessmentSettings.confidence` of :data:`ASSESSMENT`
CONFIDENCE = ASSESSMENT.confidence


def fit_percent(y: Array, y_hat: Array) -> Array:
    r"""MATLAB's ``compare`` fit per output column, in percent.

    Parameters
    ----------
    y : array_like, shape (Ns, l) or (Ns,)
        Measured output.
    y_hat : array_like, same shape as ``y``
        Simulated or predicted output.

    Returns
    -------
    ndarray, shape (l,)
        :math:`100\,(1 - \|y - \hat y\| / \|y - \bar y\|)` per column: 100 for a
        perfect model, 0 for one no better than the mean, negative (down to ``-inf``) for
        one worse than the mean; ``nan`` for a constant output.

    Notes
    -----
    The columns are scaled by a power of two first (exact;
    :func:`~hdpbsid.data.checks.scale_exponents`), so the norms of a record in extreme
    units neither underflow nor overflow.

    Examples
    --------
    >>> import numpy as np
    >>> y = np.array([[1.0], [2.0], [3.0], [4.0]])
    >>> fit_percent(y, y).tolist(), fit_percent(y, np.full((4, 1), 2.5)).tolist()
    ([100.0], [0.0])
    """
    y = np.asarray(y, dtype=float)
    y_hat = np.asarray(y_hat, dtype=float)
    p = scale_exponents(y, "y")
    if p.size == (y.shape[1] if y.ndim == 2 else 1):
        y, y_hat = np.ldexp(y, p), np.ldexp(y_hat, p)
    den = np.linalg.norm(y - y.mean(axis=0), axis=0)
    num = np.linalg.norm(y - y_hat, axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        return 100.0 * (1.0 - np.where(den > 0, num / np.where(den > 0, den, 1.0), np.nan))


@dataclass
class Comparison:
    """Result of :meth:`hdpbsid.StateSpaceModel.compare`.

    Parameters
    ----------
    fit : ndarray, shape (l,)
        Percent per output (:func:`fit_percent`).
    y_hat : ndarray, shape (Ns, l)
        The simulated (``k is None``) or ``k``-step predicted output.
    x0 : ndarray, shape (n,)
        The initial deviation state fitted by least squares.
    k : int or None
        The prediction horizon, ``None`` for simulation.

    Attributes
    ----------
    kind : str
        ``"simulation"`` or ``"<k>-step-ahead prediction"``.
    """

    fit: Array
    y_hat: Array
    x0: Array
    k: int | None

    @property
    def kind(self) -> str:
        """``"simulation"`` or ``"k-step prediction"`` in words."""
        return "simulation" if self.k is None else f"{self.k}-step-ahead prediction"

    def __repr__(self) -> str:
        return f"Comparison({self.kind}, fit={np.array2string(self.fit, precision=2)} %)"


def correlation(a: Array, b: Array, lags: Array) -> Array:
    r"""Biased cross-covariance estimate at integer lags of any sign.

    Parameters
    ----------
    a, b : ndarray, shape (N,)
        Two signals of equal length.
    lags : array_like of int
        The lags :math:`\tau`.

    Returns
    -------
    ndarray, shape (len(lags),)
        :math:`R_{ab}(\tau) = \frac1N \sum_t a(t)\, b(t - \tau)` (Ljung, *System
        Identification*, 2nd ed., 1999, eq. 16.55): the sum over the overlap divided by
        ``N``, not by the overlap's length, so that the sequence is positive semidefinite.

    Examples
    --------
    >>> import numpy as np
    >>> a = np.array([1.0, 2.0, 3.0])
    >>> correlation(a, a, [0, 1, -1]).tolist()  # (1+4+9)/3, (2+6)/3, (2+6)/3
    [4.666666666666667, 2.6666666666666665, 2.6666666666666665]
    """
    n = a.size
    out = np.empty(len(lags))
    for i, tau in enumerate(lags):
        tau = int(tau)
        if tau >= 0:
            out[i] = a[tau:] @ b[: n - tau] / n
        else:
            out[i] = a[: n + tau] @ b[-tau:] / n
    return out


@dataclass
class ResidualReport:
    r"""Residual tests (module docstring) of ``l`` outputs against ``m`` inputs.

    Parameters
    ----------
    residuals : ndarray, shape (N, l)
        The one-step prediction errors tested.
    lags : ndarray of int, shape (M + 1,)
        ``0..M``.
    autocorrelation : ndarray, shape (M + 1, l)
        :math:`r_e(\tau)`, lag 0 equal to 1.
    band : float
        The 99 % band of the autocorrelation for white errors, :math:`2.58/\sqrt N`.
    ljung_box : ndarray, shape (l,)
        The Ljung-Box statistic :math:`Q` per output.
    ljung_box_threshold : float
        The 99 % quantile of :math:`\chi^2(M)`.
    ljung_box_pvalue : ndarray, shape (l,)
        The p-value of :math:`Q`.
    cross_lags : ndarray of int, shape (2M + 1,)
        ``-M..M``.
    cross_correlation : ndarray, shape (2M + 1, l, m)
        :math:`r_{eu}(\tau)`.
    cross_band : ndarray, shape (l, m)
        The 99 % band :math:`2.58\sqrt{P/N}`.
    cross_statistic : ndarray, shape (l, m)
        :math:`\zeta = N r^T P^{-1} r` per pair.
    cross_dof : ndarray of int, shape (l, m)
        Its degrees of freedom (``2M + 1`` less the directions without excitation).
    cross_threshold : ndarray, shape (l, m)
        The 99 % quantile of :math:`\chi^2` with ``cross_dof`` degrees of freedom.
    cross_pvalue : ndarray, shape (l, m)
        The p-value of :math:`\zeta`.

    Attributes
    ----------
    max_lag : int
        ``M``.
    white_per_output : ndarray of bool, shape (l,)
        Whiteness not rejected at the 1 % level (Ljung-Box).
    independent_per_pair : ndarray of bool, shape (l, m)
        Independence from each input not rejected at the 1 % level.
    white, independent : bool
        Every output passes, every pair passes.
    """

    residuals: Array
    lags: NDArray[np.int64]
    autocorrelation: Array
    band: float
    ljung_box: Array
    ljung_box_threshold: float
    ljung_box_pvalue: Array
    cross_lags: NDArray[np.int64]
    cross_correlation: Array
    cross_band: Array
    cross_statistic: Array
    cross_dof: NDArray[np.int64]
    cross_threshold: Array
    cross_pvalue: Array

    @property
    def max_lag(self) -> int:
        """``M``, the largest lag tested."""
        return int(self.lags[-1])

    def __repr__(self) -> str:
        """The verdicts and the test statistics on one line (the arrays are attributes;
        :meth:`summary` gives one line per test)."""
        n, l = self.residuals.shape
        m = self.cross_correlation.shape[2]
        white = int(np.sum(self.white_per_output))
        q = np.array2string(self.ljung_box, precision=1, separator=", ")
        text = (
            f"ResidualReport(N={n}, M={self.max_lag}, white: {white}/{l} outputs "
            f"(Ljung-Box Q={q} vs {self.ljung_box_threshold:.1f})"
        )
        if m:
            indep = int(np.sum(self.independent_per_pair))
            text += f", independent of the input: {indep}/{l * m} pairs"
        return text + ")"

    @property
    def white_per_output(self) -> NDArray[np.bool_]:
        """Whiteness not rejected at the 1 % level, per output (Ljung-Box)."""
        return self.ljung_box <= self.ljung_box_threshold

    @property
    def independent_per_pair(self) -> NDArray[np.bool_]:
        """Independence of each input not rejected at the 1 % level, ``(l, m)``."""
        return self.cross_statistic <= self.cross_threshold

    @property
    def white(self) -> bool:
        """Every output's residual passes the whiteness test."""
        return bool(np.all(self.white_per_output))

    @property
    def independent(self) -> bool:
        """Every output's residual passes the independence test against every input."""
        return bool(np.all(self.independent_per_pair))

    def summary(
        self, output_names: list[str] | None = None, input_names: list[str] | None = None
    ) -> str:
        """The verdicts as text, one line per test.

        Parameters
        ----------
        output_names, input_names : list of str, optional
            Channel names for the lines (default ``y1, ...`` and ``u1, ...``).

        Returns
        -------
        str
            A header with ``N``, ``M`` and the band, then per output the Ljung-Box line and
            per input the cross-correlation line, each ending in its verdict.
        """
        n, l = self.residuals.shape
        m = self.cross_correlation.shape[2]
        onames = output_names or [f"y{i + 1}" for i in range(l)]
        inames = input_names or [f"u{j + 1}" for j in range(m)]
        lines = [
            f"residual tests (Ljung 16.6; N = {n}, lags up to M = {self.max_lag}, "
            f"99 % band +-{self.band:.3g}):"
        ]
        for i in range(l):
            out = np.sum(np.abs(self.autocorrelation[1:, i]) > self.band)
            verdict = "white" if self.white_per_output[i] else "NOT white"
            lines.append(
                f"  {onames[i]}: Ljung-Box Q = {self.ljung_box[i]:.1f} vs chi2_{self.max_lag} "
                f"99 % {self.ljung_box_threshold:.1f} (p = {self.ljung_box_pvalue[i]:.3g}), "
                f"{out}/{self.max_lag} lags outside the band -> {verdict}"
            )
            for j in range(m):
                cout = np.sum(np.abs(self.cross_correlation[:, i, j]) > self.cross_band[i, j])
                ok = self.independent_per_pair[i, j]
                lines.append(
                    f"  {onames[i]} vs {inames[j]}: zeta = {self.cross_statistic[i, j]:.1f} vs "
                    f"chi2_{self.cross_dof[i, j]} 99 % {self.cross_threshold[i, j]:.1f} "
                    f"(p = {self.cross_pvalue[i, j]:.3g}), {cout}/{self.cross_lags.size} lags "
                    f"outside the band -> {'independent' if ok else 'NOT independent'}"
                )
        return "\n".join(lines)


def residual_tests(e: Array, u: Array | None, max_lag: int = 25) -> ResidualReport:
    r"""Whiteness and input-independence tests of prediction errors (module docstring).

    Parameters
    ----------
    e : array_like, shape (N, l) or (N,)
        The one-step prediction errors.  Their mean is not removed: a constant error (a
        wrong operating point) is a model defect and should show.
    u : array_like, shape (N, m) or (N,), or None
        The input (``None`` or ``(N, 0)`` for a time series); its mean is removed.
    max_lag : int, optional
        ``M`` (MATLAB's default 25), ``1 <= M < N / 2``.

    Returns
    -------
    ResidualReport
        The correlations, bands, statistics, thresholds and p-values.

    Raises
    ------
    ValueError
        If ``u`` has another number of rows than ``e``, ``max_lag`` is out of range, or a
        value is not finite (the model's predictions diverged).
    TypeError
        If ``max_lag`` is not an integer.

    Notes
    -----
    Ljung (*System Identification*, 2nd ed., 1999, sec. 16.6).  Whiteness: for white ``e``
    the Ljung-Box statistic

    .. math:: Q = N (N + 2) \sum_{\tau=1}^{M} \frac{r_e(\tau)^2}{N - \tau}

    is asymptotically :math:`\chi^2(M)` (Ljung & Box, Biometrika 65, 1978).  Independence:
    :math:`\zeta = N r^T P^{-1} r` over the ``2M + 1`` cross-correlation lags with
    :math:`P_{ij} = \sum_k r_e(k)\, r_u(k + \tau_i - \tau_j)` is asymptotically
    :math:`\chi^2(2M + 1)` (eqs. 16.59-16.62); directions of ``P`` with eigenvalues below
    1e-10 of the largest (an input without excitation at those lags) are dropped with their
    degrees of freedom.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> e, u = rng.standard_normal((2000, 1)), rng.standard_normal((2000, 1))
    >>> residual_tests(e, u).white, residual_tests(np.cumsum(e, axis=0), u).white
    (True, False)
    """
    e, u = _residual_inputs(e, u, max_lag)
    n, l = e.shape
    from scipy.stats import chi2, norm  # here: scipy.stats is slow to import

    M = int(max_lag)
    z = norm.ppf(0.5 + CONFIDENCE / 2)  # 2.5758
    lags = np.arange(M + 1)
    cross_lags = np.arange(-M, M + 1)
    m = u.shape[1]
    R = np.empty((M + 1, l))
    Q = np.empty(l)
    for i in range(l):
        full = correlation(e[:, i], e[:, i], lags)
        R[:, i] = full / full[0] if full[0] > 0 else np.nan
        Q[i] = n * (n + 2) * np.sum(R[1:, i] ** 2 / (n - lags[1:]))
    q_thr = float(chi2.ppf(CONFIDENCE, M))
    uc = u - u.mean(axis=0)
    X = np.empty((2 * M + 1, l, m))
    cband = np.empty((l, m))
    zeta = np.empty((l, m))
    dof = np.zeros((l, m), dtype=np.int64)
    sym = np.arange(-M, M + 1)
    for i in range(l):
        re_full = correlation(e[:, i], e[:, i], sym)
        re = re_full / re_full[M]
        for j in range(m):
            cband[i, j], zeta[i, j], dof[i, j] = _cross_test(X, i, j, e, uc, re_full, re, z)
    cthr = np.where(dof > 0, chi2.ppf(CONFIDENCE, np.maximum(dof, 1)), np.inf)
    return ResidualReport(
        residuals=e,
        lags=lags,
        autocorrelation=R,
        band=float(z / np.sqrt(n)),
        ljung_box=Q,
        ljung_box_threshold=q_thr,
        ljung_box_pvalue=chi2.sf(Q, M),
        cross_lags=cross_lags,
        cross_correlation=X,
        cross_band=cband,
        cross_statistic=zeta,
        cross_dof=dof,
        cross_threshold=np.asarray(cthr, dtype=float).reshape(l, m),
        cross_pvalue=np.asarray(chi2.sf(zeta, np.maximum(dof, 1)), dtype=float).reshape(l, m),
    )


def _residual_inputs(e: Any, u: Any, max_lag: Any) -> tuple[Array, Array]:
    """The residuals and input of :func:`residual_tests` as columns, checked."""
    e = np.asarray(e, dtype=float)
    if e.ndim == 1:
        e = e[:, None]
    n = e.shape[0]
    u = np.zeros((n, 0)) if u is None else np.asarray(u, dtype=float)
    if u.ndim == 1:
        u = u[:, None]
    if u.shape[0] != n:
        raise ValueError(f"u must have {n} rows like the residuals, got shape {u.shape}")
    if isinstance(max_lag, bool) or not isinstance(max_lag, int | np.integer):
        raise TypeError(f"max_lag must be an integer, got {max_lag!r}")
    if not 1 <= max_lag < n / 2:
        raise ValueError(f"max_lag must be between 1 and N/2 = {n / 2:g}, got {max_lag}")
    if not (np.all(np.isfinite(e)) and np.all(np.isfinite(u))):
        raise ValueError("residuals and input must be finite (the model's predictions diverged?)")
    return e, u


def _cross_test(
    X: Array, i: int, j: int, e: Array, uc: Array, re_full: Array, re: Array, z: float
) -> tuple[float, float, int]:
    """The cross-correlation test of residual ``i`` and centred input ``j``: writes the
    normalised cross-correlation into ``X[:, i, j]`` and returns its band, its statistic
    and the statistic's degrees of freedom (:func:`residual_tests`, Notes)."""
    n = e.shape[0]
    M = (X.shape[0] - 1) // 2
    cross_lags = np.arange(-M, M + 1)
    sym = np.arange(-M, M + 1)
    ru_full = correlation(uc[:, j], uc[:, j], np.arange(-3 * M, 3 * M + 1))
    ru = ru_full / ru_full[3 * M] if ru_full[3 * M] > 0 else np.zeros_like(ru_full)
    X[:, i, j] = correlation(e[:, i], uc[:, j], cross_lags) / np.sqrt(
        re_full[M] * max(ru_full[3 * M], np.finfo(float).tiny)
    )
    # P_ab = sum_k r_e(k) r_u(k + tau_a - tau_b), |k| <= M (Ljung eq. 16.59/16.61)
    d = cross_lags[:, None] - cross_lags[None, :]
    P = np.zeros((2 * M + 1, 2 * M + 1))
    for kk, rek in zip(sym, re, strict=True):
        P += rek * ru[3 * M + kk + d]
    P = 0.5 * (P + P.T)
    cband = z * np.sqrt(max(float(np.diag(P).mean()), 0.0) / n)
    w, V = np.linalg.eigh(P)
    keep = w > 1e-10 * max(float(w.max()), np.finfo(float).tiny)
    proj = V[:, keep].T @ X[:, i, j]
    return cband, n * float(np.sum(proj**2 / w[keep])), int(keep.sum())
