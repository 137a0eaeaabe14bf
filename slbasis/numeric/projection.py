"""Streaming projection of sampled signals onto the orthonormal functions, and reconstruction.

With the time map ``x = (t - centre) * scale`` (:class:`~slbasis.numeric.timemap.TimeMap`)
the L^2(dt)-orthonormal functions are ``phi_n(t) = sqrt(scale) phi_n(x(t))`` and

    c_n = int y(t) phi_n(t) dt  ~=  sum_j v_j y(t_j) phi_n(t_j)                       (1)

with sample weights ``v_j`` from the sample spacing (:func:`sample_weights`): the
trapezoid rule (any spacing, error ``O(h^2)`` in general and spectrally small for
integrands that decay at the window ends, by Euler–Maclaurin) or, for uniform spacing,
Gregory's end-corrected rule of order ``h^4`` (weights ``3/8, 7/6, 23/24, 1, ...``;
Press et al., *Numerical Recipes*, 3rd ed., eq. 4.1.14).

``method="lstsq"`` instead minimises ``sum_j v_j (y_j - sum_n c_n phi_n(t_j))^2``
(weighted least squares; normal equations ``G c = Phi V y`` with ``G = Phi V Phi^T``
accumulated over chunks, solved by Cholesky). Since ``G`` is the discrete Gram matrix,
``G ~= I`` when the sampling resolves the functions and both methods agree; ``lstsq`` is
exact for signals in the span even when sampling is coarse, at ``O(N^2)`` cost per sample.

Both stream over chunks of samples: only an ``N x chunk`` block of function values
exists at any time (the default chunk keeps it below ``memory`` bytes, 64 MB), so
``10^6`` samples onto ``2000`` functions never build the 16 GB matrix.
"""

from __future__ import annotations

import warnings

import numpy as np
import scipy.linalg as sla

from slbasis.runtime import user_stacklevel

from . import engine as _engine
from .evaluate import Recurrence, _split_log, evaluate
from .kernel import Kernel
from .timemap import TimeMap
from .validate import as_int_at_least, as_signal, as_times

__all__ = ["sample_weights", "project", "project_alternating", "reconstruct", "default_chunk"]

_MEMORY = 64 * 2**20
_FUSED_MAX_SIGNALS = 8  # more signals: blocks of function values times BLAS are faster
_SINGULAR = (
    "t: the basis functions are infinite at some sample times (a singular "
    "interval end?); sample strictly inside the interval"
)


def default_chunk(N: int, memory: int = _MEMORY) -> int:
    """Samples per chunk so that an ``N x chunk`` float64 block fits in ``memory`` bytes.

    Parameters
    ----------
    N : int
        Number of functions.
    memory : int, optional
        Bytes of the block (default 64 MB).

    Returns
    -------
    int
        The chunk, between 64 and 16384 samples.

    Examples
    --------
    >>> default_chunk(2000)
    4194
    """
    return int(min(16384, max(64, memory // (8 * max(N, 1)))))


#: relative tolerance of a uniform spacing, that of ``hdpbsid.data.checks.UNIFORM_RTOL``
_UNIFORM_RTOL = 1e-6


def _is_uniform(t: np.ndarray) -> bool:
    """Whether ``t`` is uniform for the Gregory weights: every spacing within
    ``1e-6 h + 4 ulp(max |t|)`` of the median spacing ``h`` (computed on ``t - t[0]``).

    The rule of ``hdpbsid.data.checks.is_uniform``, repeated because ``slbasis`` sits below
    ``hdpbsid`` and imports nothing from it; one rule, so that a grid is uniform for both
    packages.  ``4 ulp``: each difference of two stamps is known to two spacings of
    ``max |t|`` (stored, and computed as ``t0 + k h``), and so is the median it is
    compared with; a grid stamped with absolute time (``t ~ 1.7e9``) is as uniform as
    its stamps can say.  Within ``1e-6 h`` the Gregory weights of the mean spacing err by
    at most ~1e-6 relative, the accuracy at which a grid is one sampled model elsewhere.
    """
    tr = t - t[0]
    dt = np.diff(tr)
    h = float(np.median(dt))
    tol = _UNIFORM_RTOL * h + 4.0 * float(np.spacing(np.max(np.abs(t))))
    return bool(np.all(np.abs(dt - h) <= tol))


def sample_weights(t: np.ndarray, rule: str = "trapezoid") -> np.ndarray:
    """Quadrature weights ``v_j`` with ``int_{t_0}^{t_end} f dt ~= sum_j v_j f(t_j)``.

    Parameters
    ----------
    t : array_like, shape (Ns,)
        Increasing sample times, at least 2.
    rule : {"trapezoid", "gregory"}, optional
        ``"trapezoid"``: any increasing ``t``, error ``O(h^2)`` (spectrally small for
        integrands that decay at the window ends, by Euler-Maclaurin); ``"gregory"``:
        uniform ``t`` with at least 8 samples, the end-corrected rule of order ``h^4``.

    Returns
    -------
    ndarray, shape (Ns,)
        The weights.

    Raises
    ------
    ValueError
        If ``rule`` is unknown, or ``"gregory"`` gets fewer than 8 or non-uniform samples.

    References
    ----------
    .. [1] W. H. Press, S. A. Teukolsky, W. T. Vetterling and B. P. Flannery, *Numerical
       Recipes*, 3rd ed., Cambridge University Press, 2007, eq. 4.1.14.

    Examples
    --------
    >>> sample_weights(np.array([0.0, 1.0, 3.0]))
    array([0.5, 1.5, 1. ])
    >>> sample_weights(np.arange(10.0), "gregory").round(4)
    array([0.375 , 1.1667, 0.9583, 1.    , 1.    , 1.    , 1.    , 0.9583, 1.1667,
           0.375 ])
    """
    ta = as_times(t, "t", min_len=2)
    dt = np.diff(ta)
    if rule == "trapezoid":
        v = np.empty_like(ta)
        v[0] = dt[0] / 2
        v[-1] = dt[-1] / 2
        v[1:-1] = (dt[:-1] + dt[1:]) / 2
        return v
    if rule == "gregory":
        if ta.size < 8:
            raise ValueError(f"t: rule='gregory' needs at least 8 samples, got {ta.size}")
        if not _is_uniform(ta):
            raise ValueError("t: rule='gregory' needs uniformly spaced samples")
        h = (ta[-1] - ta[0]) / (ta.size - 1)
        v = np.full(ta.size, h)
        end = h * np.array([3 / 8, 7 / 6, 23 / 24])
        v[:3] = end
        v[-3:] = end[::-1]
        return v
    raise ValueError(f"rule: expected 'trapezoid' or 'gregory', got {rule!r}")


def _resolve_weights(t: np.ndarray, weights) -> np.ndarray:
    if isinstance(weights, str):
        return sample_weights(t, weights)
    v = np.asarray(weights, dtype=float)
    if v.shape != t.shape:
        raise ValueError(f"weights: expected shape {t.shape}, got {v.shape}")
    if not np.all(np.isfinite(v)) or np.any(v < 0):
        raise ValueError("weights: must be finite and non-negative")
    return v


def project(
    kernel: Kernel,
    N: int,
    tmap: TimeMap,
    t: np.ndarray,
    y: np.ndarray,
    *,
    method: str = "quadrature",
    weights: str | np.ndarray = "trapezoid",
    chunk: int | None = None,
    engine: str = "auto",
) -> np.ndarray:
    """Coefficients ``c_n = int y phi_n dt`` (eq. 1), streaming over chunks of samples.

    With ``method="quadrature"`` the integral is the weighted sum over the samples; with
    ``"lstsq"`` the coefficients minimise ``sum_j v_j (y_j - sum_n c_n phi_n(t_j))^2`` (the
    normal equations with the discrete Gram matrix, accumulated over chunks), exact for
    signals in the span even when the sampling is coarse.  With the ``"numba"`` engine,
    ``"quadrature"`` and at most 8 signals the sums run fused with the recurrence (no block
    of function values is stored).

    Parameters
    ----------
    kernel : Kernel
        The family.
    N : int
        Number of functions.
    tmap : TimeMap
        The map from time to the family's variable.
    t : array_like, shape (Ns,)
        Increasing sample times.
    y : array_like, shape (Ns,) or (Ns, k)
        The samples (``scipy.signal.lsim``'s convention).
    method : {"quadrature", "lstsq"}, optional
        The projection.
    weights : str or ndarray, optional
        A rule of :func:`sample_weights` or per-sample weights (finite, non-negative).
    chunk : int, optional
        Samples per block (default :func:`default_chunk`).
    engine : {"auto", "numpy", "numba"}, optional
        The engine (:mod:`slbasis.numeric.engine`).

    Returns
    -------
    ndarray, shape (N,) or (N, k)
        The coefficients.

    Raises
    ------
    ValueError
        If ``method`` is unknown, the weights are invalid, or the functions are infinite at
        a sample time (a singular interval end).

    Examples
    --------
    ``y = t`` on ``[0, 2]`` in orthonormal Legendre functions:

    >>> import slbasis
    >>> from slbasis.numeric.timemap import TimeMap
    >>> t = np.linspace(0.0, 2.0, 201)
    >>> c = project(slbasis.kernel("legendre"), 3, TimeMap(1.0, 1.0), t, t, method="lstsq")
    >>> c.round(6) + 0.0
    array([1.414214, 0.816497, 0.      ])
    """
    N = as_int_at_least(N, "N")
    ta = as_times(t, "t", min_len=2)
    ya = as_signal(y, ta.size, "y")
    if method not in ("quadrature", "lstsq"):
        raise ValueError(f"method: expected 'quadrature' or 'lstsq', got {method!r}")
    chunk = default_chunk(N) if chunk is None else as_int_at_least(chunk, "chunk")
    v = _resolve_weights(ta, weights)
    x = tmap.to_x(ta)
    root = np.sqrt(tmap.scale)
    y2 = ya.reshape(ta.size, -1)
    vy = (v * root)[:, None] * y2
    rec = Recurrence(kernel, N)
    use = _engine.resolve(engine, _engine.work(N, ta.size))
    if use == "numba" and method == "quadrature" and 1 <= y2.shape[1] <= _FUSED_MAX_SIGNALS:
        c = _project_fused(kernel, rec, N, x, vy)
        return c.reshape((N,) + ya.shape[1:])
    c = np.zeros((N, y2.shape[1]))
    G = np.zeros((N, N)) if method == "lstsq" else None
    buf = np.empty((N, chunk))
    for s in range(0, ta.size, chunk):
        sl = slice(s, min(s + chunk, ta.size))
        w = sl.stop - sl.start
        P = evaluate(kernel, N, x[sl], out=buf[:, :w] if w == chunk else None, rec=rec, engine=use)
        if not np.all(np.isfinite(P[-1])) or not np.all(np.isfinite(P[0])):
            raise ValueError(_SINGULAR)
        c += P @ vy[sl]
        if G is not None:
            Pv = P * (v[sl] * tmap.scale)
            G += Pv @ P.T
    if G is not None:
        c = _solve_gram(G, c)
    return c.reshape((N,) + ya.shape[1:])


def project_alternating(
    kernel: Kernel,
    N: int,
    tmap: TimeMap,
    t: np.ndarray,
    y_even: np.ndarray,
    y_odd: np.ndarray,
    *,
    weights: str | np.ndarray = "trapezoid",
    engine: str = "auto",
) -> np.ndarray:
    """Coefficients of the even functions on ``y_even`` and of the odd ones on ``y_odd``.

    This is the projection of a record sampled symmetrically about the centre of a basis
    with parity, ``phi_n(-x) = (-1)^n phi_n(x)`` (Hermite functions, Legendre
    polynomials): each mirrored pair of samples ``x, -x`` contributes ``phi_n(x) (y(x) +
    (-1)^n y(-x))``, so the projection (1) over all samples is the sum of Returns over the
    samples with ``x >= 0``, ``y_even = y(x) + y(-x)``, ``y_odd = y(x) - y(-x)``: half the
    samples.  The compiled
    engine (``k <= 8``) sums each row against the signals it needs only; the numpy engine
    projects both and selects.

    Parameters
    ----------
    kernel : Kernel
        The family.
    N : int
        Number of functions.
    tmap : TimeMap
        The map from time to the family's variable.
    t : array_like, shape (Ns,)
        Increasing sample times.
    y_even : array_like, shape (Ns,) or (Ns, k)
        The signals of the even rows.
    y_odd : array_like, shape (Ns,) or (Ns, k)
        The signals of the odd rows, shaped like ``y_even``.
    weights : str or ndarray, optional
        As in :func:`project`.
    engine : {"auto", "numpy", "numba"}, optional
        The engine.

    Returns
    -------
    ndarray, shape (N,) or (N, k)
        ``c_n = sum_j v_j phi_n(t_j) y_even(t_j)`` for even ``n``, ``y_odd`` for odd ``n``.

    Raises
    ------
    ValueError
        If ``y_odd`` is not shaped like ``y_even``, or from :func:`project`.
    """
    ta = as_times(t, "t", min_len=2)
    ye = as_signal(y_even, ta.size, "y_even")
    yo = as_signal(y_odd, ta.size, "y_odd")
    if ye.shape != yo.shape:
        raise ValueError(f"y_odd: expected the shape of y_even {ye.shape}, got {yo.shape}")
    N = as_int_at_least(N, "N")
    k = ye.reshape(ta.size, -1).shape[1]
    both = np.hstack([ye.reshape(ta.size, -1), yo.reshape(ta.size, -1)])
    use = _engine.resolve(engine, _engine.work(N, ta.size))
    if use == "numba" and 1 <= k <= _FUSED_MAX_SIGNALS:
        v = _resolve_weights(ta, weights)
        vy = (v * np.sqrt(tmap.scale))[:, None] * both
        c = _project_fused(kernel, Recurrence(kernel, N), N, tmap.to_x(ta), vy, columns=k)
    else:
        full = project(kernel, N, tmap, ta, both, weights=weights, engine=use).reshape(N, -1)
        c = full[:, :k].copy()
        c[1::2] = full[1::2, k:]
    return c.reshape((N,) + ye.shape[1:])


def _project_fused(
    kernel: Kernel,
    rec: Recurrence,
    N: int,
    x: np.ndarray,
    vy: np.ndarray,
    columns: int | None = None,
):
    """``Phi(x) @ vy`` by the compiled fused kernel (same checks as the blocked loop);
    ``columns``: as in :func:`slbasis.numeric.engine.project_compiled`."""
    x = np.ascontiguousarray(x)
    logabs, sign = kernel.log_phi0(x)
    m0, e0 = _split_log(np.asarray(logabs, dtype=float), np.asarray(sign, dtype=float))
    with np.errstate(over="ignore"):
        row0_finite = bool(np.all(np.isfinite(np.ldexp(m0, e0))))
    with np.errstate(invalid="ignore", over="ignore"):
        c, bad = _engine.project_compiled(
            rec, N, x, m0, e0, vy.T, rec.renorm_mask(x, N), columns=columns
        )
    if bad or not row0_finite:
        raise ValueError(_SINGULAR)
    return c


def _solve_gram(G: np.ndarray, r: np.ndarray) -> np.ndarray:
    evals = np.linalg.eigvalsh(G)
    cond = evals[-1] / evals[0] if evals[0] > 0 else np.inf
    if cond < 1e12:
        return sla.cho_solve(sla.cho_factor(G), r)
    warnings.warn(
        f"project(method='lstsq'): the sampled Gram matrix is ill-conditioned "
        f"(cond ~ {cond:.1e}); the samples do not resolve all N functions. Using a "
        "minimum-norm least-squares solution.",
        RuntimeWarning,
        stacklevel=user_stacklevel(),
    )
    return sla.lstsq(G, r, cond=1e-12)[0]


def reconstruct(
    kernel: Kernel,
    N: int,
    tmap: TimeMap,
    c: np.ndarray,
    t: np.ndarray,
    *,
    chunk: int | None = None,
    engine: str = "auto",
) -> np.ndarray:
    """``y(t) = sum_n c_n phi_n(t)``.

    Blocks of ``chunk`` samples are evaluated by ``engine`` and multiplied by ``c`` (BLAS).

    Parameters
    ----------
    kernel : Kernel
        The family.
    N : int
        Number of functions.
    tmap : TimeMap
        The map from time to the family's variable.
    c : array_like, shape (N,) or (N, k)
        Coefficients, finite.
    t : array_like, shape (Ns,)
        Times (any order).
    chunk : int, optional
        Samples per block.
    engine : {"auto", "numpy", "numba"}, optional
        The engine.

    Returns
    -------
    ndarray, shape (Ns,) or (Ns, k)
        The values.

    Raises
    ------
    ValueError
        If ``c`` has the wrong shape or is not finite.

    Examples
    --------
    >>> import slbasis
    >>> from slbasis.numeric.timemap import TimeMap
    >>> c = np.array([np.sqrt(2.0), 0.0, 0.0])  # the constant 1 on [0, 2]
    >>> reconstruct(slbasis.kernel("legendre"), 3, TimeMap(1.0, 1.0), c, np.array([0.0, 1.0]))
    array([1., 1.])
    """
    N = as_int_at_least(N, "N")
    ta = as_times(t, "t", increasing=False)
    ca = np.asarray(c, dtype=float)
    if ca.ndim not in (1, 2) or ca.shape[0] != N:
        raise ValueError(f"c: expected shape ({N},) or ({N}, k), got {ca.shape}")
    if not np.all(np.isfinite(ca)):
        raise ValueError("c: contains NaN or inf")
    chunk = default_chunk(N) if chunk is None else as_int_at_least(chunk, "chunk")
    x = tmap.to_x(ta)
    c2 = ca.reshape(N, -1) * np.sqrt(tmap.scale)
    out = np.empty((ta.size, c2.shape[1]))
    rec = Recurrence(kernel, N)
    use = _engine.resolve(engine, _engine.work(N, ta.size))
    for s in range(0, ta.size, chunk):
        sl = slice(s, min(s + chunk, ta.size))
        out[sl] = evaluate(kernel, N, x[sl], rec=rec, engine=use).T @ c2
    return out.reshape(ta.shape + ca.shape[1:])
