"""Models fitted to frequency-response data, and the figure comparing them with the data.

:func:`identify_frequency` fits a continuous-time :class:`~hdpbsid.models.model.StateSpaceModel`
to frequency-response data (see its docstring); :func:`plot_frf` draws an estimate with its
confidence region and a model over it.  The non-parametric estimates themselves
(:class:`FrequencyResponse`, :func:`frf_welch`, :func:`frf_periodic`,
:func:`effective_averages`) are in :mod:`hdpbsid.frequency.estimate` and importable from
here; :func:`hdpbsid.frequency.delay.estimate_delay` estimates an input-output dead time.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hdpbsid.data.checks import as_float_array, check_positive_int
from hdpbsid.frequency.estimate import (
    FrequencyResponse,
    effective_averages,
    frf_periodic,
    frf_welch,
)
from hdpbsid.models.model import StateSpaceModel
from hdpbsid.models.uncertainty import ParameterCovariance, covariance_factor, response_band

__all__ = [
    "FrequencyResponse",
    "frf_welch",
    "frf_periodic",
    "effective_averages",
    "FitSettings",
    "FIT",
    "identify_frequency",
    "fit_cost",
    "plot_frf",
]

Array = NDArray[np.float64]
CArray = NDArray[np.complex128]


@dataclass(frozen=True)
class FitSettings:
    """Settings of :func:`identify_frequency`'s order selection and refinement.

    Attributes
    ----------
    folds : int
        Interleaved folds of the held-out-lines order selection: line ``k`` is held out in
        fold ``k mod folds``.
    max_nfev : int
        Residual evaluations allowed to one refinement.
    """

    #: every fold spans the whole band and every line is judged once, by a model fitted
    #: on the other two thirds
    folds: int = 3
    #: from the subspace start a model of the data's order converges in tens; the cap
    #: bounds the cost of the over-parametrised orders the selection also fits (which then
    #: stop short of their optimum, i.e. are judged no better than they are)
    max_nfev: int = 200


#: the settings :func:`identify_frequency` uses
FIT = FitSettings()


# -- models from frequency data ------------------------------------------------------------
def identify_frequency(
    w: Any,
    H: Any | None = None,
    order: int | None = None,
    weight: Any = "auto",
    *,
    max_order: int | None = None,
    feedthrough: bool = False,
    refine: bool = True,
) -> StateSpaceModel:
    """Continuous-time state-space model from frequency-response data.

    1. **Subspace start** (McKelvey, Akcay & Ljung, "Subspace-based multivariable system
       identification from frequency response data", IEEE Trans. Autom. Control 41(7),
       1996, the algorithm for arbitrary frequencies): the frequencies are mapped to the
       unit circle by the bilinear map ``z = (w_c + s) / (w_c - s)`` with ``w_c`` the
       geometric mean of the band (so the band's logarithmic centre lands at ``z = j``
       and a band of decades is spread over the circle); the block-Hankel-like matrices
       ``[z_k^i H_k]`` and ``[z_k^i I]`` (``i < q``, ``q = 2 n + 2``), in real form and
       weighted per frequency, give the extended observability matrix as the dominant
       left singular vectors of the first orthogonalised against the second; ``A``,
       ``C`` by shift invariance, mapped back by ``A_c = w_c (A_d - I)(A_d + I)^{-1}``
       (exact: ``(zI - A_d) = (I + A_d)(sI - A_c) / (w_c - s)``), then ``B`` (and ``D``)
       by weighted linear least squares.
    2. **Refinement**: weighted nonlinear least squares
       (:func:`scipy.optimize.least_squares`) of ``sum |W (G(j w) - H)|^2`` over a real
       modal parametrisation (``A`` block-diagonal: each real eigenvalue, each pair's
       real and imaginary parts; ``B``, ``C`` and ``D`` free).  With ``W = 1 / sigma``
       this is the maximum-likelihood estimate for circular complex Gaussian errors of
       standard deviation ``sigma`` (Pintelon & Schoukens 2012, sec. 9.2-9.3).
    3. **Order** (``order=None``): each order from 1 to ``max_order`` is fitted on two
       thirds of the lines and scored on the held-out third, for three interleaved folds,
       so every line is scored once by a model that did not see it; the order is the
       smallest whose total held-out weighted error is within one standard error of the
       best (:func:`hdpbsid.models.criteria.choose_smallest_adequate`, the rule the time-domain
       selection uses).  Held-out lines judge what the data support without a noise level
       or a penalty to choose (an AIC needs the noise variance; singular-value gaps vanish
       in noise), and the interleaving keeps every fold over the whole band.

    Weights ``W`` (``weight``): ``"auto"`` uses the estimate's variance when ``w`` is a
    :class:`FrequencyResponse` that carries one (``1 / sqrt(variance)``), else its
    coherence (``"coherence"``), else ``"relative"``; ``"coherence"``: ``sqrt(gamma^2 /
    (1 - gamma^2)) / |H|``, proportional to ``1 / sigma`` of an H1 estimate (its variance
    is ``(1 - gamma^2) |H|^2 / (gamma^2 n)``, Bendat & Piersol eq. 9.90);
    ``"relative"``: ``1 / |H|``, each decade of a Bode plot alike (the error is then
    close to the log-magnitude and phase error); ``None``: uniform; or an array
    broadcastable to ``H``.

    Parameters
    ----------
    w : ndarray, shape (nf,), or FrequencyResponse
        Angular frequencies (rad/s), or a :class:`FrequencyResponse` (then ``H`` is taken from
        it).
    H : ndarray of complex, shape (nf,) or (l, m, nf), optional
        Frequency response (SISO or MIMO); not with a ``FrequencyResponse``.
    order : int or None, optional
        Model order, or ``None`` to choose it.
    weight : {"auto", "coherence", "relative"}, array_like or None, optional
        The weights ``W`` described above.
    max_order : int or None, optional
        Largest order tried (default :data:`hdpbsid.data.checks.DEFAULT_MAX_ORDER`, at most what
        the lines support).
    feedthrough : bool, optional
        Fit ``D`` (default: strictly proper, ``D = 0``).
    refine : bool, optional
        Run the nonlinear refinement (else the subspace start is returned).

    Returns
    -------
    StateSpaceModel
        ``K = 0``; ``options`` holds ``method="frequency"``, the order, ``w_c``, the
        weighted cost, the refinement's parameter covariance ``covariance`` (of the modal
        parameters, ``s^2 (J^T J)^+``) and, when the order was chosen, ``selection`` (one
        row per order: held-out error and its statistic).

    Raises
    ------
    ValueError
        On non-positive or repeated frequencies, non-finite ``H``, mismatched shapes or
        too few lines for the order.

    Examples
    --------
    >>> A = np.array([[0.0, 1.0], [-4.0, -0.8]]); B = np.array([[0.0], [1.0]])
    >>> C = np.array([[1.0, 0.0]])
    >>> w = np.logspace(-1, 1.5, 60)
    >>> H = (C @ np.linalg.solve(1j * w[:, None, None] * np.eye(2) - A, B))[:, 0, 0]
    >>> model = identify_frequency(w, H, order=2)
    >>> bool(np.allclose(np.sort_complex(model.eigenvalues), np.sort_complex(np.linalg.eigvals(A))))
    True
    """
    from hdpbsid.data.checks import DEFAULT_MAX_ORDER

    w_arr, Hc, W, source, wc = _prepared(w, H, weight, order, feedthrough)
    l, m, nf = Hc.shape
    n_real = 2 * nf * m * l  # real equations
    if order is not None:
        order = check_positive_int(order, "order")
    mo = DEFAULT_MAX_ORDER if max_order is None else check_positive_int(max_order, "max_order")
    selection = None
    if order is None:
        order, selection = _select_order(w_arr, Hc, W, wc, mo, feedthrough, refine)
    model_parts, info = _fit_order(w_arr, Hc, W, order, wc, feedthrough, refine)
    A, B, C, D = model_parts
    options: dict[str, Any] = dict(
        method="frequency",
        order=order,
        w_c=wc,
        weight=weight if isinstance(weight, str) or weight is None else "given",
        weight_source=source,
        feedthrough=feedthrough,
        refine=refine,
        lines=nf,
        equations=n_real,
        **info,
    )
    if selection is not None:
        options["selection"] = selection
    cov = None
    if "covariance" in info:
        cov = ParameterCovariance(_full_factor(info, l, m, feedthrough), "identify_frequency")
    return StateSpaceModel(
        A, B, C, D, np.zeros((A.shape[0], l)), options=options, parameter_covariance=cov
    )


def _prepared(
    w: Any, H: Any, weight: Any, order: int | None, feedthrough: bool
) -> tuple[Array, CArray, Array, str, float]:
    """The checked lines, response and weights, the weights' source, and the centre
    ``w_c`` of the bilinear map (the band's geometric mean); refuses an order the lines
    cannot determine."""
    w_arr, Hc, W, source = _frequency_data(w, H, weight)
    l, m, nf = Hc.shape
    if order is not None:
        _check_enough_lines(check_positive_int(order, "order"), l, m, nf, feedthrough, "order")
    return w_arr, Hc, W, source, float(np.sqrt(w_arr.min() * w_arr.max()))


def fit_cost(
    w: Any, H: Any, order: int, weight: Any = "auto", *, feedthrough: bool = False
) -> float:
    """The weighted cost ``sum_k |W_k (G(j w_k) - H_k)|^2`` of the refined fit of order
    ``order`` that :func:`identify_frequency` returns, without building the model.

    Parameters
    ----------
    w : array_like, shape (nf,), or FrequencyResponse
        Angular frequencies (rad/s), or an estimate (then ``H`` is None).
    H : array_like of complex or None
        Response, shape ``(nf,)`` or ``(l, m, nf)``.
    order : int
        Model order.
    weight : str, array_like or None, optional
        As :func:`identify_frequency`'s ``weight``.
    feedthrough : bool, optional
        Fit a direct term ``D``.

    Returns
    -------
    float
        The cost of the fit (the start's, when the refinement did not lower it).

    Raises
    ------
    ValueError
        When the lines cannot determine a model of ``order`` (as
        :func:`identify_frequency`).

    Examples
    --------
    >>> w = np.logspace(-1, 1, 40)
    >>> H = 1.0 / (1j * w + 2.0)
    >>> bool(fit_cost(w, H, 1) < 1e-12)
    True
    """
    w_arr, Hc, W, _, wc = _prepared(w, H, weight, order, feedthrough)
    _, info = _fit_order(w_arr, Hc, W, int(order), wc, feedthrough, True)
    return float(info["cost"])


def _full_factor(info: dict[str, Any], l: int, m: int, feedthrough: bool) -> Array:
    """The covariance factor of ``[vec A, vec B, vec C, vec D]``
    (:class:`hdpbsid.models.uncertainty.ParameterCovariance`) from the modal parameters'
    covariance of :func:`_refine`: ``A`` is linear in the modal parameters (a real
    eigenvalue sets its diagonal entry; a pair ``(sigma, omega)`` its block
    ``[[sigma, omega], [-omega, sigma]]``), ``B``, ``C``, ``D`` are parameters themselves
    (``D`` fixed at zero without feedthrough)."""
    lay = info["parameter_layout"]
    nr, npair, n = lay["real"], lay["pairs"], lay["states"]
    P = np.asarray(info["covariance"]).shape[0]
    M = np.zeros((n * n + n * m + l * n + l * m, P))
    for i in range(nr):
        M[i * n + i, i] = 1.0
    for k in range(npair):
        i, c = nr + 2 * k, nr + 2 * k
        M[i * n + i, c] = M[(i + 1) * n + i + 1, c] = 1.0  # sigma
        M[i * n + i + 1, c + 1], M[(i + 1) * n + i, c + 1] = 1.0, -1.0  # omega
    rows = n * n
    cols = nr + 2 * npair
    size = n * m + l * n
    M[rows : rows + size, cols : cols + size] = np.eye(size)
    if feedthrough:
        M[rows + size :, cols + size :] = np.eye(l * m)
    return M @ covariance_factor(info["covariance"])


def _frequency_data(w: Any, H: Any, weight: Any) -> tuple[Array, CArray, Array, str]:
    frf = w if isinstance(w, FrequencyResponse) else None
    if frf is not None:
        if H is not None:
            raise ValueError("H must not be given with a FrequencyResponse (it holds H)")
        w, H = frf.w, frf.H
    w_arr = as_float_array(w, "w").reshape(-1)
    if w_arr.size < 2 or np.any(w_arr <= 0) or np.any(np.diff(np.sort(w_arr)) <= 0):
        raise ValueError("w must hold at least 2 distinct positive frequencies (rad/s)")
    if H is None:
        raise ValueError("H must be given (or pass a FrequencyResponse as w)")
    Hc = np.asarray(H, dtype=complex)
    if Hc.ndim == 1:
        Hc = Hc[None, None, :]
    if Hc.ndim != 3 or Hc.shape[2] != w_arr.size:
        raise ValueError(
            f"H must have shape (nf,) or (l, m, nf) with nf = {w_arr.size} lines, got {Hc.shape}"
        )
    if not np.all(np.isfinite(Hc)):
        raise ValueError(
            "H must be finite: identify_frequency needs every entry at every line (for an "
            "orthogonal multi-input periodic design, identify each input's lines apart)"
        )
    W, source = _weights(weight, Hc, frf)
    return w_arr, Hc, W, source


def _weights(weight: Any, H: CArray, frf: FrequencyResponse | None) -> tuple[Array, str]:
    """The weights ``W`` of :func:`identify_frequency` (its docstring) and their source."""
    if isinstance(weight, str):
        name = _weight_name(weight, frf)
        return np.broadcast_to(_named_weight(name, H, frf), H.shape).astype(float), name
    if weight is None:
        return np.ones(H.shape), "uniform"
    W = as_float_array(weight, "weight")
    try:
        W = np.broadcast_to(W, H.shape).astype(float)
    except ValueError as exc:
        raise ValueError(f"weight must broadcast to H's shape {H.shape}, got {W.shape}") from exc
    if np.any(W < 0):
        raise ValueError("weight must be non-negative")
    return W, "given"


def _weight_name(weight: str, frf: FrequencyResponse | None) -> str:
    """``"auto"`` resolved: the estimate's variance when it carries one, else its
    coherence, else the relative weight; any other name as given."""
    if weight != "auto":
        return weight
    if frf is not None and frf.variance is not None:
        return "variance"
    if frf is not None and frf.coherence is not None:
        return "coherence"
    return "relative"


def _named_weight(name: str, H: CArray, frf: FrequencyResponse | None) -> Array:
    """The weight called ``name``: ``1 / sqrt(variance)``, the coherence weight or ``1 / |H|``."""
    absH = np.maximum(np.abs(H), np.finfo(float).tiny)
    if name == "variance":
        if frf is None or frf.variance is None:
            raise ValueError("weight='variance' needs a FrequencyResponse with a variance")
        return 1.0 / np.sqrt(np.maximum(frf.variance, np.finfo(float).tiny))
    if name == "coherence":
        if frf is None or frf.coherence is None:
            raise ValueError("weight='coherence' needs a FrequencyResponse with a coherence")
        # 1 - 1e-12: a coherence of one (noise-free) keeps a finite, very large weight
        g2 = np.clip(frf.coherence, 0.0, 1.0 - 1e-12)[:, None, :]
        return np.sqrt(g2 / (1.0 - g2)) / absH
    if name == "relative":
        return 1.0 / absH
    raise ValueError(
        "weight must be 'auto', 'variance', 'coherence', 'relative', None or an "
        f"array, got {name!r}"
    )


def _transfer(A: Array, B: Array, C: Array, D: Array, s: CArray) -> CArray:
    """``C (sI - A)^{-1} B + D`` at every ``s``: (l, m, ns), as
    :meth:`hdpbsid.models.model.StateSpaceModel.frequency_response` lays it out."""
    n = A.shape[0]
    X = np.linalg.solve(
        s[:, None, None] * np.eye(n)[None] - A[None], np.broadcast_to(B, (s.size,) + B.shape)
    )
    return np.moveaxis(np.einsum("ij,kjl->kil", C, X) + D[None], 0, -1)


def _n_params(n: int, l: int, m: int, feedthrough: bool) -> int:
    return n + n * (m + l) + (l * m if feedthrough else 0)


def _check_enough_lines(n: int, l: int, m: int, nf: int, feedthrough: bool, name: str) -> None:
    need = _n_params(n, l, m, feedthrough)
    have = 2 * nf * l * m
    if have <= need or nf < n + 1:
        raise ValueError(
            f"{name} {n} needs more than {need} real equations and {n + 1} lines; the data "
            f"give {have} equations on {nf} lines"
        )


def _subspace_start(w: Array, H: CArray, W: Array, n: int, wc: float) -> tuple[Array, Array]:
    """``(A_c, C_c)`` of order ``n`` by the frequency-domain subspace method on the
    bilinear-mapped unit circle (:func:`identify_frequency`, step 1)."""
    l, m, nf = H.shape
    q = max(n + 1, min(2 * n + 2, nf // 2))
    z = (wc + 1j * w) / (wc - 1j * w)
    scale = np.mean(W, axis=(0, 1))  # one weight per frequency keeps the column relation
    zp = z[None, :] ** np.arange(q)[:, None]  # (q, nf)
    Gq = np.einsum("ik,abk,k->iakb", zp, H, scale).reshape(q * l, nf * m)
    Wq = np.einsum("ik,ab,k->iakb", zp, np.eye(m), scale).reshape(q * m, nf * m)
    Gr = np.hstack([Gq.real, Gq.imag])
    Wr = np.hstack([Wq.real, Wq.imag])
    R = np.linalg.qr(np.vstack([Wr, Gr]).T, mode="r").T
    R22 = R[q * m :, q * m :]
    U, _, _ = np.linalg.svd(R22, full_matrices=False)
    O = U[:, :n]
    Cd = O[:l]
    Ad = np.linalg.lstsq(O[:-l], O[l:], rcond=None)[0]
    Ip = Ad + np.eye(n)
    Ac = wc * np.linalg.solve(Ip.T, (Ad - np.eye(n)).T).T
    Cc = np.linalg.solve(Ip.T, Cd.T).T
    return Ac, Cc


def _fit_bd(
    w: Array, H: CArray, W: Array, A: Array, C: Array, feedthrough: bool
) -> tuple[Array, Array]:
    """``B``, ``D`` minimising ``sum |W (C (jwI - A)^{-1} B + D - H)|^2`` (linear)."""
    l, m, nf = H.shape
    n = A.shape[0]
    Phi = np.einsum(
        "ij,kjl->kil", C, np.linalg.inv(1j * w[:, None, None] * np.eye(n)[None] - A[None])
    )  # (nf, l, n)
    B = np.zeros((n, m))
    D = np.zeros((l, m))
    for j in range(m):
        Wj = W[:, j, :].T  # (nf, l)
        M = Phi * Wj[:, :, None]
        if feedthrough:
            M = np.concatenate([M, np.eye(l)[None] * Wj[:, :, None]], axis=2)
        M = M.reshape(nf * l, -1)
        rhs = (H[:, j, :].T * Wj).reshape(-1)
        x = np.linalg.lstsq(
            np.vstack([M.real, M.imag]), np.concatenate([rhs.real, rhs.imag]), rcond=None
        )[0]
        B[:, j] = x[:n]
        if feedthrough:
            D[:, j] = x[n:]
    return B, D


def _to_modal(A: Array, B: Array, C: Array) -> tuple[Array, Array, Array, Array, Array]:
    """Real modal form: ``(real eigenvalues, pairs (sigma, omega) (p, 2), A_m, B_m, C_m)``."""
    from scipy.linalg import cdf2rdf

    lam, V = np.linalg.eig(A)
    order = np.lexsort((np.abs(lam.imag), lam.real))
    lam, V = lam[order], V[:, order]
    # make conjugate pairs adjacent, positive imaginary part first (cdf2rdf's convention)
    real = [i for i in range(lam.size) if abs(lam[i].imag) <= 1e-12 * max(abs(lam[i]), 1.0)]
    upper = [i for i in range(lam.size) if lam[i].imag > 1e-12 * max(abs(lam[i]), 1.0)]
    idx: list[int] = list(real)
    for i in upper:
        j = int(np.argmin(np.abs(lam - np.conj(lam[i]))))
        idx += [i, j]
    lam, V = lam[idx], V[:, idx]
    lam[: len(real)] = lam[: len(real)].real
    V[:, : len(real)] = V[:, : len(real)].real
    for k in range(len(real), lam.size, 2):  # exact conjugates for cdf2rdf
        lam[k + 1] = np.conj(lam[k])
        V[:, k + 1] = np.conj(V[:, k])
    wr, vr = cdf2rdf(lam, V)
    T = np.real(vr)
    Am = np.real(wr)
    Bm = np.linalg.solve(T, B)
    Cm = C @ T
    reals = lam[: len(real)].real
    pairs = np.array([[lam[k].real, lam[k].imag] for k in range(len(real), lam.size, 2)])
    return reals, pairs.reshape(-1, 2), Am, Bm, Cm


def _modal_a(reals: Array, pairs: Array) -> Array:
    n = reals.size + 2 * pairs.shape[0]
    A = np.zeros((n, n))
    A[np.arange(reals.size), np.arange(reals.size)] = reals
    for k, (s, om) in enumerate(pairs):
        i = reals.size + 2 * k
        A[i : i + 2, i : i + 2] = [[s, om], [-om, s]]
    return A


def _modal_jacobian(
    A: Array, B: Array, C: Array, s: CArray, nr: int, npair: int, feedthrough: bool
) -> CArray:
    """Derivatives of ``G(s) = C (sI - A)^{-1} B + D`` with respect to the modal parameters,
    in the order of :func:`_refine`'s vector: ``(P, l, m, ns)``.

    With ``Phi = C (sI - A)^{-1}`` and ``Psi = (sI - A)^{-1} B``: ``dG / dA_pq = Phi[:, p]
    Psi[q, :]`` (from ``d(M^{-1}) = -M^{-1} dM M^{-1}``), ``dG_ij / dB_pj = Phi_ip``,
    ``dG_ij / dC_ip = Psi_pj``, ``dG_ij / dD_ij = 1``.  A real eigenvalue moves ``A_pp``; a
    pair ``(sigma, omega)`` moves its block by ``I`` and by ``[[0, 1], [-1, 0]]``.
    """
    n, m = B.shape
    l = C.shape[0]
    Rinv = np.linalg.inv(s[:, None, None] * np.eye(n)[None] - A[None])  # (ns, n, n)
    Phi = np.einsum("ip,kpq->kiq", C, Rinv)  # (ns, l, n)
    Psi = np.einsum("kpq,qj->kpj", Rinv, B)  # (ns, n, m)

    def outer(p: int, q: int) -> CArray:  # dG / dA_pq: (l, m, ns)
        return np.einsum("ki,kj->ijk", Phi[:, :, p], Psi[:, q, :])

    rows: list[CArray] = [outer(p, p) for p in range(nr)]
    for k in range(npair):
        i = nr + 2 * k
        rows.append(outer(i, i) + outer(i + 1, i + 1))
        rows.append(outer(i, i + 1) - outer(i + 1, i))
    ns = s.size
    dB = np.zeros((n, m, l, m, ns), dtype=complex)
    for j in range(m):
        dB[:, j, :, j, :] = np.moveaxis(Phi, 0, -1).transpose(1, 0, 2)
    dC = np.zeros((l, n, l, m, ns), dtype=complex)
    for i in range(l):
        dC[i, :, i, :, :] = np.moveaxis(Psi, 0, -1)
    parts = [np.stack(rows) if rows else np.zeros((0, l, m, ns), complex)]
    parts += [dB.reshape(n * m, l, m, ns), dC.reshape(l * n, l, m, ns)]
    if feedthrough:
        dD = np.zeros((l, m, l, m, ns), dtype=complex)
        for i in range(l):
            for j in range(m):
                dD[i, j, i, j, :] = 1.0
        parts.append(dD.reshape(l * m, l, m, ns))
    return np.concatenate(parts, axis=0)


def _refine(
    w: Array, H: CArray, W: Array, A: Array, B: Array, C: Array, D: Array, feedthrough: bool
) -> tuple[tuple[Array, Array, Array, Array], dict[str, Any]]:
    from scipy.optimize import least_squares

    l, m, _ = H.shape
    reals, pairs, _, Bm, Cm = _to_modal(A, B, C)
    nr, npair = reals.size, pairs.shape[0]
    n = nr + 2 * npair
    sizes = [nr, 2 * npair, n * m, l * n] + ([l * m] if feedthrough else [])
    theta0 = np.concatenate(
        [reals, pairs.reshape(-1), Bm.reshape(-1), Cm.reshape(-1)]
        + ([D.reshape(-1)] if feedthrough else [])
    )
    cuts = np.cumsum(sizes)[:-1]
    s = 1j * w

    def unpack(theta: Array) -> tuple[Array, Array, Array, Array]:
        parts = np.split(theta, cuts)
        Am = _modal_a(parts[0], parts[1].reshape(-1, 2))
        Dm = parts[4].reshape(l, m) if feedthrough else np.zeros((l, m))
        return Am, parts[2].reshape(n, m), parts[3].reshape(l, n), Dm

    def residual(theta: Array) -> Array:
        G = _transfer(*unpack(theta), s)
        e = (W * (G - H)).reshape(-1)
        return np.concatenate([e.real, e.imag])

    def jacobian(theta: Array) -> Array:
        Am, Bm, Cm, _ = unpack(theta)
        dG = _modal_jacobian(Am, Bm, Cm, s, nr, npair, feedthrough)  # (P, l, m, nf)
        J = (W[None] * dG).reshape(dG.shape[0], -1).T
        return np.vstack([J.real, J.imag])

    res = least_squares(
        residual, theta0, jac=jacobian, method="lm", x_scale="jac", max_nfev=FIT.max_nfev
    )
    theta = res.x
    r0 = residual(theta0)
    dof = max(res.fun.size - theta.size, 1)
    s2 = float(res.fun @ res.fun) / dof
    J = res.jac
    cov = s2 * np.linalg.pinv(J.T @ J)
    cost0, cost = float(r0 @ r0), float(res.fun @ res.fun)
    if not np.isfinite(cost) or cost > cost0:  # keep the start if the refinement lost
        theta, cost = theta0, cost0
    info = dict(
        cost_start=cost0,
        cost=cost,
        nfev=int(res.nfev),
        covariance=cov,
        parameters=theta,
        parameter_layout=dict(real=nr, pairs=npair, states=n),
    )
    return unpack(theta), info


def _fit_order(
    w: Array, H: CArray, W: Array, n: int, wc: float, feedthrough: bool, refine: bool
) -> tuple[tuple[Array, Array, Array, Array], dict[str, Any]]:
    A, C = _subspace_start(w, H, W, n, wc)
    B, D = _fit_bd(w, H, W, A, C, feedthrough)
    if not refine:
        G = _transfer(A, B, C, D, 1j * w)
        return (A, B, C, D), dict(cost=float(np.sum(np.abs(W * (G - H)) ** 2)))
    return _refine(w, H, W, A, B, C, D, feedthrough)


def _select_order(
    w: Array, H: CArray, W: Array, wc: float, max_order: int, feedthrough: bool, refine: bool
) -> tuple[int, list[dict[str, Any]]]:
    from hdpbsid.models.criteria import WindowedError, choose_smallest_adequate

    l, m, nf = H.shape
    fold = np.arange(nf) % FIT.folds
    errors: list[WindowedError] = []
    orders: list[int] = []
    for n in range(1, max_order + 1):
        try:
            _check_enough_lines(n, l, m, int(np.sum(fold != 0)), feedthrough, "order")
        except ValueError:
            break
        per_line = np.empty(nf)
        finite = True
        for f in range(FIT.folds):
            est, held = fold != f, fold == f
            try:
                (A, B, C, D), _ = _fit_order(
                    w[est], H[..., est], W[..., est], n, wc, feedthrough, refine
                )
                G = _transfer(A, B, C, D, 1j * w[held])
                per_line[held] = np.sum(np.abs(W[..., held] * (G - H[..., held])) ** 2, axis=(0, 1))
            except (np.linalg.LinAlgError, ValueError):
                finite = False
        finite = finite and bool(np.all(np.isfinite(per_line)))
        total = float(np.sum(per_line)) if finite else np.inf
        errors.append(WindowedError(per_line, total, np.nan, finite))
        orders.append(n)
    if not errors:
        raise ValueError(f"too few lines ({nf}) to choose an order")
    chosen, stats = choose_smallest_adequate(errors)
    rows = [
        dict(order=o, held_out_error=e.total, z=z, chosen=(i == chosen))
        for i, (o, e, z) in enumerate(zip(orders, errors, stats, strict=True))
    ]
    return orders[chosen], rows


# -- figure -----------------------------------------------------------------------------------
def plot_frf(
    frf: FrequencyResponse,
    model: StateSpaceModel | None = None,
    alpha: float = 0.05,
    output: int = 0,
    input: int = 0,
) -> Any:
    """Bode magnitude and phase of an estimate with its ``1 - alpha`` confidence band
    (from :meth:`FrequencyResponse.confidence_radius`: ``|H| +- r`` and ``+- asin(r /
    |H|)`` in phase), a model's response over it with the model's own pointwise ``1 -
    alpha`` band when it carries a parameter covariance
    (:func:`hdpbsid.models.uncertainty.response_band`, the delta method), and the coherence
    with its bounds: the comparison of a parametric model with the non-parametric
    estimate a reviewer asks for.

    Parameters
    ----------
    frf : FrequencyResponse
        The estimate.
    model : StateSpaceModel or None, optional
        Optional model drawn over it.
    alpha : float, optional
        Level of the bands.
    output, input : int
        The channel drawn.

    Returns
    -------
    matplotlib.figure.Figure
        Three axes: magnitude, phase, coherence.

    Raises
    ------
    TypeError
        If ``frf`` is not a :class:`FrequencyResponse`.
    """
    import matplotlib.pyplot as plt

    if not isinstance(frf, FrequencyResponse):
        raise TypeError(f"frf must be a FrequencyResponse, got {type(frf).__name__}")
    fig, axes = plt.subplots(3, 1, figsize=(7, 7), sharex=True, layout="constrained")
    w, H = frf.w, frf.H[output, input]
    ok = np.isfinite(H)
    w, H = w[ok], H[ok]
    phase = _draw_estimate(axes, frf, w, H, ok, alpha, (output, input))
    if model is not None:
        _draw_model(axes, model, w, phase, alpha, (output, input))
    if frf.coherence is not None:
        c = frf.coherence[output][ok]
        axes[2].semilogx(w, c, ".", ms=3, label="coherence")
        if frf.dof is not None:
            clo, chi = frf.coherence_bounds(alpha)
            axes[2].fill_between(w, clo[output][ok], chi[output][ok], alpha=0.3, lw=0)
    axes[0].set_ylabel("|H| (dB)")
    axes[0].legend(fontsize=8)
    axes[1].set_ylabel("phase (deg)")
    axes[2].set_ylabel("coherence")
    axes[2].set_ylim(0, 1.05)
    axes[2].set_xlabel("w (rad/s)")
    return fig


def _draw_estimate(
    axes: Any,
    frf: FrequencyResponse,
    w: Array,
    H: CArray,
    ok: NDArray[np.bool_],
    alpha: float,
    channel: tuple[int, int],
) -> Array:
    """The estimate's magnitude and phase with its confidence region; returns the
    unwrapped phase (degrees) the model's phase is aligned with."""
    mag = np.abs(H)
    phase = np.degrees(np.unwrap(np.angle(H)))
    axes[0].semilogx(w, 20 * np.log10(mag), ".", ms=3, label=f"{frf.method} estimate")
    axes[1].semilogx(w, phase, ".", ms=3)
    if frf.variance is not None and frf.dof is not None:
        r = frf.confidence_radius(alpha)[channel][ok]
        # a region reaching zero is drawn down to -40 dB below the estimate
        lo = 20 * np.log10(np.maximum(mag - r, 0.01 * mag))
        axes[0].fill_between(
            w,
            lo,
            20 * np.log10(mag + r),
            alpha=0.3,
            lw=0,
            label=f"{100 * (1 - alpha):.0f} % region",
        )
        dph = np.degrees(np.arcsin(np.clip(r / mag, 0.0, 1.0)))
        axes[1].fill_between(w, phase - dph, phase + dph, alpha=0.3, lw=0)
    return phase


def _draw_model(
    axes: Any,
    model: StateSpaceModel,
    w: Array,
    phase: Array,
    alpha: float,
    channel: tuple[int, int],
) -> None:
    """The model's response over the estimate's band, its phase shifted by whole turns
    onto the estimate's, with its band when it carries a parameter covariance."""
    wd = np.geomspace(w.min(), w.max(), 400)
    G = model.frequency_response(wd)[channel]
    axes[0].semilogx(wd, 20 * np.log10(np.abs(G)), "-", lw=1.2, color="C1", label="model")
    gph = np.degrees(np.unwrap(np.angle(G)))
    shift = 360.0 * np.round((phase[0] - np.interp(w[0], wd, gph)) / 360.0)
    axes[1].semilogx(wd, gph + shift, "-", lw=1.2, color="C1")
    if model.parameter_covariance is None:
        return
    band = response_band(model, wd, alpha)
    lo, _, hi = (x[channel] for x in band.magnitude_db())
    axes[0].fill_between(
        wd,
        lo,
        hi,
        color="C1",
        alpha=0.25,
        lw=0,
        label=f"model {100 * (1 - alpha):.0f} % band (parameter covariance)",
    )
    plo, pc, phi = (x[channel] for x in band.phase_deg())
    off = gph + shift - pc
    axes[1].fill_between(wd, plo + off, phi + off, color="C1", alpha=0.25, lw=0)
