"""Exact conversion between continuous-time and ZOH-sampled innovation models.

Convention (stated once, used everywhere in hdpbsid): the continuous-time innovation
model ``dx/dt = A x + B u + K e``, ``y = C x + D u + e`` is sampled with period ``T``
treating **both** ``u`` and ``e`` as held constant over each interval (zero-order hold).
Then, with the augmented matrix (Franklin, Powell & Workman, *Digital Control*, sec. 6.3;
Van Loan 1978)

    expm([[A, B, K], [0, 0, 0], [0, 0, 0]] T) = [[Ad, Bd, Kd], [0, I, 0], [0, 0, I]],

``Ad = e^{A T}``, ``[Bd, Kd] = int_0^T e^{A s} ds [B, K]``, and ``C, D`` are unchanged.
The sampled model ``x_{k+1} = Ad x_k + Bd u_k + Kd e_k``, ``y_k = C x_k + D u_k + e_k``
has the same one-step predictor as the held-innovation continuous model, which is what a
sampled-data subspace method estimates.  (This is *not* the Kalman-Bucy gain of a model
driven by continuous white noise; for that, ``K`` has to be recomputed from the
continuous noise intensities.)

``d2c`` inverts the map with the principal matrix logarithm of the augmented matrix.  It
exists as a real matrix only when ``Ad`` has no eigenvalue on the closed negative real
axis (zero included), and it returns the sampled continuous model only when every
continuous eigenvalue satisfies ``|Im(lambda)| T < pi`` (no aliasing: the Nyquist
condition).

The augmented matrix is block triangular with an identity block, so its logarithm needs
only functions of ``Ad``: with ``L = [[X, Y], [0, 0]]``, ``expm(L) = [[e^X, psi(X) Y],
[0, I]]``, ``psi(X) = (e^X - I) X^{-1} = sum_k X^k / (k + 1)!``, hence

    logm([[Ad, G], [0, I]]) = [[log(Ad), phi(Ad) G], [0, 0]],   phi(x) = log(x) / (x - 1)

(``phi(1) = 1``; ``phi(Ad) = psi(log Ad)^{-1}``, which exists because ``psi`` has no zero
on the principal strip ``|Im| < pi``).  :func:`d2c` evaluates ``log`` and ``phi`` on the
eigenvalues of ``Ad``, ``f(Ad) = V f(Lambda) V^{-1}``, when its eigenvector matrix has
``cond(V) <= MAX_LOG_CONDITION`` (rounding ``cond(V) eps``, Higham, *Functions of
Matrices*, 2008, sec. 4.5), or up to ``CHECKED_LOG_CONDITION`` when the exponential of
the result gives back the augmented matrix to ``LOG_BACKWARD_TOL`` (a backward-error
check), and with :func:`scipy.linalg.logm` of the whole augmented matrix otherwise
(nearly defective ``Ad``).  The eigenvalue route comes first because it is one
eigendecomposition, while the generic algorithm (inverse scaling and squaring with norm
estimates, Al-Mohy & Higham 2012) takes many matrix square roots, and an order sweep of
``method="dt"`` converts one model per order.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.linalg import expm, logm

from hdpbsid.data.checks import check_state_space
from hdpbsid.models.recursion import modal_form
from hdpbsid.runtime import user_stacklevel

__all__ = [
    "ConversionSettings",
    "CONVERSION",
    "c2d",
    "d2c",
    "sampled_steps",
    "check_log_exists",
    "MAX_LOG_CONDITION",
    "CHECKED_LOG_CONDITION",
    "LOG_BACKWARD_TOL",
]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class ConversionSettings:
    """Where the conversions switch between their exact routes, and how closely they check.

    Attributes
    ----------
    max_log_condition : float
        Largest eigenvector condition of ``Ad`` for the a priori eigenvalue route of
        :func:`d2c`.
    checked_log_condition : float
        Largest one for the eigenvalue route with the backward check.
    log_backward_tol : float
        Largest relative backward error of the checked eigenvalue route.
    phi_series_radius : float
        ``|x - 1|`` below which ``log(x) / (x - 1)`` is summed as its series.
    steps_modal_min : int
        Distinct steps from which :func:`sampled_steps` takes the eigenvalue route.
    phi2_series_radius : float
        ``|z|`` below which ``phi_2(z)`` is summed as its series.
    """

    #: largest eigenvector condition number of ``Ad`` for the eigenvalue route of
    #: :func:`d2c` (module docstring): its rounding, about ``cond(V) eps``, then stays below
    #: 1e-12 relative, within a factor 100 of the generic logarithm's
    max_log_condition: float = 1e4
    #: up to this ``cond(V)`` the eigenvalue route is still tried, and kept when its result
    #: passes the backward check of :func:`_reproduces` (the exponential of the logarithm
    #: found gives back the augmented matrix to :data:`LOG_BACKWARD_TOL`): an a posteriori
    #: test instead of the a priori bound.  Sampled models of closed-loop records of
    #: moderate order often have ``cond(V)`` of a few times 1e4, where the a priori bound
    #: would send them to the much slower generic logarithm although the eigenvalue route is
    #: exact to rounding; the check keeps what is exact and rejects what is not
    checked_log_condition: float = 1e8
    #: largest relative backward error ``||expm(L) - M||_1 / ||M||_1`` of the checked
    #: eigenvalue route: a hundred times the rounding of the exponential itself
    #: (``~ n eps``, ``n <= 100`` here), so what passes is as exact as the data allow
    log_backward_tol: float = 1e-11
    #: ``|x - 1|`` below which ``phi(x) = log(x) / (x - 1)`` is summed as its series
    #: ``1 - d/2 + d^2/3 - d^3/4`` (``d = x - 1``; truncation ``d^4 / 5 < 1e-17``)
    phi_series_radius: float = 1e-4
    #: :func:`sampled_steps` takes the eigenvalue route from this many distinct steps on
    #: (below, the batched ``expm`` costs about as little)
    steps_modal_min: int = 8
    #: ``|z|`` below which ``phi_2(z) = (e^z - 1 - z) / z^2`` is summed as its series (16
    #: terms: truncation below ``0.5^16 / 18! ~ 2e-21``); above, the closed form loses at
    #: most ``eps / |z| <= 2 eps`` to cancellation
    phi2_series_radius: float = 0.5


#: The settings in force.
CONVERSION = ConversionSettings()
#: :attr:`ConversionSettings.max_log_condition` of :data:`CONVERSION`
MAX_LOG_CONDITION = CONVERSION.max_log_condition
#: :attr:`ConversionSettings.checked_log_condition` of :data:`CONVERSION`
CHECKED_LOG_CONDITION = CONVERSION.checked_log_condition
#: :attr:`ConversionSettings.log_backward_tol` of :data:`CONVERSION`
LOG_BACKWARD_TOL = CONVERSION.log_backward_tol

_PHI2_COEFFS = 1.0 / np.array([float(np.prod(np.arange(1, k + 3))) for k in range(16)])


def _phi12(z: NDArray[np.complex128]) -> tuple[NDArray, NDArray]:
    """``phi_1(z) = (e^z - 1) / z`` and ``phi_2(z) = (e^z - 1 - z) / z^2`` elementwise
    (``phi_1(0) = 1``, ``phi_2(0) = 1/2``), both accurate to rounding for every ``z``."""
    small = np.abs(z) < CONVERSION.phi2_series_radius
    zs = np.where(small, z, 0.0)
    series = np.zeros_like(z)
    for c in _PHI2_COEFFS[::-1]:
        series = series * zs + c
    zl = np.where(small, 1.0, z)
    em1 = np.expm1(zl)
    phi2 = np.where(small, series, (em1 - zl) / zl**2)
    phi1 = np.where(small, 1.0 + z * series, em1 / zl)
    return phi1, phi2


def _augmented_steps(
    A: Array, B: Array, K: Array | None, h: Array, foh: bool
) -> tuple[Array, Array, Array | None, Array | None]:
    """:func:`sampled_steps` by the exponential of the augmented matrix of every step."""
    n, m = B.shape
    mu = 2 * m if foh else m
    lk = 0 if K is None else K.shape[1]
    size = n + mu + lk
    M = np.zeros((h.size, size, size))
    M[:, :n, :n] = A[None] * h[:, None, None]
    M[:, :n, n : n + m] = B[None] * h[:, None, None]
    if foh:
        M[:, n : n + m, n + m : n + 2 * m] = np.eye(m)[None]
    if K is not None:
        M[:, :n, n + mu :] = K[None] * h[:, None, None]
    E = expm(M)
    G2 = E[:, :n, n + m : n + 2 * m] if foh else None
    Gk = E[:, :n, n + mu :] if K is not None else None
    return E[:, :n, :n], E[:, :n, n : n + m], G2, Gk


def sampled_steps(
    A: Array, B: Array, K: Array | None, h: Array, hold: str
) -> tuple[Array, Array, Array | None, Array | None]:
    r"""Exact one-step matrices of ``dx/dt = A x + B u (+ K e)`` for every step length.

    Parameters
    ----------
    A : ndarray, shape (n, n)
        State matrix.
    B : ndarray, shape (n, m)
        Input matrix.
    K : ndarray, shape (n, l), or None
        Innovation gain; ``None`` when the innovation steps are not needed.
    h : array_like, shape (k,)
        The step lengths (positive).
    hold : {"zoh", "foh"}
        The input between samples: held (``"zoh"``) or linear (``"foh"``).

    Returns
    -------
    Phi : ndarray, shape (k, n, n)
        ``e^{A h}``.
    G1 : ndarray, shape (k, n, m)
        ``h phi_1(A h) B``, which multiplies ``u_k``.
    G2 : ndarray, shape (k, n, m), or None
        ``h phi_2(A h) B``, which multiplies ``u_{k+1} - u_k`` (``hold="foh"`` only).
    Gk : ndarray, shape (k, n, l), or None
        ``h phi_1(A h) K``, which multiplies the innovation held over the step (the
        module's convention; ``K`` given only).

    Notes
    -----
    The blocks of the augmented exponential (Franklin, Powell & Workman, *Digital Control
    of Dynamic Systems*, 3rd ed., 1998, sec. 6.3)

    .. math::

        \exp\begin{bmatrix} A h & B h & 0 & K h \\ 0 & 0 & I & 0 \\ 0 & 0 & 0 & 0
        \\ 0 & 0 & 0 & 0 \end{bmatrix}

    are :math:`e^{Ah}`, :math:`h\varphi_1(Ah)B`, :math:`h\varphi_2(Ah)B` and
    :math:`h\varphi_1(Ah)K` with :math:`\varphi_1(z) = (e^z - 1)/z` and
    :math:`\varphi_2(z) = (e^z - 1 - z)/z^2`.  With many distinct steps (non-uniform times)
    they are evaluated on the eigenvalues of ``A``, :math:`f(Ah) = V f(\Lambda h) V^{-1}`,
    for all steps at once, when :math:`\operatorname{cond}(V) \le`
    :data:`MAX_LOG_CONDITION` (rounding about :math:`\operatorname{cond}(V)\,\epsilon`,
    Higham, *Functions of Matrices*, 2008, sec. 4.5) and the longest step agrees with its
    augmented exponential to :data:`LOG_BACKWARD_TOL` relative; otherwise (few steps, a
    nearly defective ``A``) by one augmented exponential per step, whose cost grows with the
    number of distinct steps.
    """
    h = np.asarray(h, dtype=float)
    foh = hold == "foh"
    modal = modal_form(A, MAX_LOG_CONDITION) if h.size >= CONVERSION.steps_modal_min else None
    if modal is None:
        return _augmented_steps(A, B, K, h, foh)
    lam, V, Vi = modal
    Z = h[:, None] * lam[None, :]
    phi1, phi2 = _phi12(Z)

    def through(f: NDArray, R: Array | None) -> Array:
        # V diag(f_k) V^{-1} R for every step k, real (A is real)
        right = Vi if R is None else Vi @ R
        return np.einsum("ij,kj,jl->kil", V, f, right).real

    hcol = h[:, None]
    Phi = through(np.exp(Z), None)
    G1 = through(hcol * phi1, B)
    G2 = through(hcol * phi2, B) if foh else None
    Gk = through(hcol * phi1, K) if K is not None else None
    ref = _augmented_steps(A, B, K, h[[int(np.argmax(h))]], foh)
    i = int(np.argmax(h))
    got = [Phi[i], G1[i]] + ([G2[i]] if foh else []) + ([Gk[i]] if K is not None else [])
    want = [M[0] for M in ref if M is not None]
    scale = max(max(np.abs(W).max() for W in want), np.finfo(float).tiny)
    if max(np.abs(g - w).max() for g, w in zip(got, want, strict=True)) > LOG_BACKWARD_TOL * scale:
        return _augmented_steps(A, B, K, h, foh)
    return Phi, G1, G2, Gk


def _reproduces(L: Array, M: Array) -> bool:
    """Whether ``expm`` of the augmented logarithm with first block row ``L`` (``n`` rows
    of the ``N x N`` matrix ``M``; the other rows zero) gives back ``M`` to
    :data:`LOG_BACKWARD_TOL` relative (1-norm)."""
    n, N = L.shape
    full = np.zeros((N, N))
    full[:n] = L
    with np.errstate(all="ignore"):
        err = np.abs(expm(full) - M).sum(axis=0).max()
    return bool(err <= LOG_BACKWARD_TOL * np.abs(M).sum(axis=0).max())


def _log_and_phi(Ad: Array, max_condition: float) -> tuple[Array, Array] | None:
    """``(log(Ad), phi(Ad))`` on the eigenvalues of ``Ad`` (module docstring), or None when
    ``cond(V) > max_condition`` (or the decomposition is not finite)."""
    modal = modal_form(Ad, max_condition)
    if modal is None:
        return None
    lam, V, Vi = modal
    lam = lam.astype(complex)
    log_lam = np.log(lam)  # principal branch; no eigenvalue on (-inf, 0] (checked)
    d = lam - 1.0
    near = np.abs(d) < CONVERSION.phi_series_radius
    phi = np.where(near, 1.0 - d / 2 + d**2 / 3 - d**3 / 4, log_lam / np.where(near, 1.0, d))
    return (V * log_lam) @ Vi, (V * phi) @ Vi


def _check_dt(dt: float) -> float:
    if isinstance(dt, bool) or not isinstance(dt, int | float | np.floating | np.integer):
        raise TypeError(f"dt must be a positive real number, got {type(dt).__name__}")
    dt = float(dt)
    if not np.isfinite(dt) or dt <= 0:
        raise ValueError(f"dt must be a positive finite sampling interval, got {dt}")
    return dt


def c2d(
    A: Array, B: Array, C: Array, D: Array | None, K: Array | None, dt: float
) -> tuple[Array, Array, Array, Array, Array]:
    r"""Zero-order-hold sampling of an innovation model ``(A, B, C, D, K)``.

    Parameters
    ----------
    A : array_like, shape (n, n)
        Continuous state matrix.
    B : array_like, shape (n, m)
        Input matrix.
    C : array_like, shape (l, n)
        Output matrix.
    D : array_like, shape (l, m), or None
        Feedthrough (default zeros).
    K : array_like, shape (n, l), or None
        Innovation gain (default zeros).
    dt : float
        Sampling interval, positive and finite.

    Returns
    -------
    Ad, Bd, C, D, Kd : ndarray
        The sampled model ``x_{k+1} = Ad x_k + Bd u_k + Kd e_k``, ``y_k = C x_k + D u_k + e_k``.

    Raises
    ------
    ValueError
        If the shapes disagree, an entry is not finite, or ``dt`` is not positive.
    TypeError
        If ``dt`` is not a real number.

    Notes
    -----
    With ``u`` and ``e`` both held over each interval (the module's convention; Van Loan,
    *Computing integrals involving the matrix exponential*, IEEE TAC 23, 1978)

    .. math::

        \exp\left(\begin{bmatrix} A & B & K \\ 0 & 0 & 0 \\ 0 & 0 & 0 \end{bmatrix}
        T\right) = \begin{bmatrix} A_d & B_d & K_d \\ 0 & I & 0 \\ 0 & 0 & I
        \end{bmatrix}.

    Examples
    --------
    >>> import numpy as np
    >>> from hdpbsid import c2d
    >>> Ad, Bd, C, D, Kd = c2d([[-1.0]], [[1.0]], [[1.0]], None, None, 0.5)
    >>> bool(np.isclose(Ad[0, 0], np.exp(-0.5))), bool(np.isclose(Bd[0, 0], 1 - np.exp(-0.5)))
    (True, True)
    """
    A, B, C, D, K = check_state_space(A, B, C, D, K)
    dt = _check_dt(dt)
    n, m, l = A.shape[0], B.shape[1], C.shape[0]
    M = np.zeros((n + m + l, n + m + l))
    M[:n, :n] = A
    M[:n, n : n + m] = B
    M[:n, n + m :] = K
    E = expm(M * dt)
    return E[:n, :n], E[:n, n : n + m], C.copy(), D.copy(), E[:n, n + m :]


def check_log_exists(Ad: Array, rtol: float = 1e-10) -> None:
    """Raise when ``Ad`` has no real matrix logarithm.

    Parameters
    ----------
    Ad : ndarray, shape (n, n)
        A sampled state matrix.
    rtol : float, optional
        An eigenvalue counts as real when ``|Im| <= rtol * max(|lambda|, 1)``; as zero when
        ``|lambda| <= rtol * max(1, ||Ad||_2)``.

    Raises
    ------
    ValueError
        If ``Ad`` has an eigenvalue at zero (``e^{A dt}`` is invertible, so no continuous
        model exists) or on the negative real axis (no real logarithm: a sign-alternating
        mode faster than Nyquist, or an identification artefact).
    """
    ev = np.linalg.eigvals(Ad)
    scale = max(1.0, float(np.linalg.norm(Ad, 2))) if Ad.size else 1.0
    for lam in ev:
        if abs(lam) <= rtol * scale:
            raise ValueError(
                f"Ad has an eigenvalue at zero ({lam:.3g}): a ZOH-sampled continuous model "
                f"never has one (e^(A dt) is invertible), so no continuous model exists"
            )
        if abs(lam.imag) <= rtol * max(abs(lam), 1.0) and lam.real < 0:
            raise ValueError(
                f"Ad has an eigenvalue on the negative real axis ({lam.real:.6g}): it has no "
                f"real matrix logarithm, so no real continuous-time model sampled with ZOH "
                f"gives this discrete model (a sign alternating mode faster than Nyquist, or "
                f"an identification artefact); reduce the order or resample"
            )


def d2c(
    Ad: Array, Bd: Array, C: Array, D: Array | None, Kd: Array | None, dt: float
) -> tuple[Array, Array, Array, Array, Array]:
    r"""Exact inverse of :func:`c2d` by the principal logarithm of the augmented matrix.

    Parameters
    ----------
    Ad : array_like, shape (n, n)
        Sampled state matrix.
    Bd : array_like, shape (n, m)
        Sampled input matrix.
    C : array_like, shape (l, n)
        Output matrix.
    D : array_like, shape (l, m), or None
        Feedthrough (default zeros).
    Kd : array_like, shape (n, l), or None
        Sampled innovation gain (default zeros).
    dt : float
        Sampling interval, positive and finite.

    Returns
    -------
    A, B, C, D, K : ndarray
        The continuous model whose :func:`c2d` is the input.

    Raises
    ------
    ValueError
        If ``Ad`` has an eigenvalue on the closed negative real axis (no real logarithm:
        :func:`check_log_exists`), the shapes disagree, or ``dt`` is not positive.

    Warns
    -----
    RuntimeWarning
        When the logarithm needed a complex part of non-negligible size (eigenvalues of
        ``Ad`` near the negative real axis, ``|Im(lambda)| dt`` near ``pi``).

    Notes
    -----
    ``[A, B, K]`` is the first block row of
    :math:`\log\begin{bmatrix} A_d & B_d & K_d \\ 0 & I & 0 \\ 0 & 0 & I \end{bmatrix}
    / \Delta t = [\log A_d,\; \phi(A_d)[B_d, K_d]] / \Delta t`,
    :math:`\phi(x) = \log(x)/(x - 1)` (module docstring); it returns the sampled
    continuous model only when every continuous eigenvalue has
    :math:`|\operatorname{Im}\lambda|\,\Delta t < \pi` (no aliasing).

    Examples
    --------
    >>> import numpy as np
    >>> from hdpbsid import c2d, d2c
    >>> A, B, C = [[0.0, 1.0], [-4.0, -0.4]], [[0.0], [1.0]], [[1.0, 0.0]]
    >>> A2, B2, _, _, _ = d2c(*c2d(A, B, C, None, None, 0.1), 0.1)
    >>> bool(np.allclose(A2, A)), bool(np.allclose(B2, B))
    (True, True)
    """
    Ad, Bd, C, D, Kd = check_state_space(Ad, Bd, C, D, Kd)
    dt = _check_dt(dt)
    check_log_exists(Ad)
    n, m, l = Ad.shape[0], Bd.shape[1], C.shape[0]
    M = np.eye(n + m + l)
    M[:n, :n] = Ad
    M[:n, n : n + m] = Bd
    M[:n, n + m :] = Kd
    L = None
    by_eig = _log_and_phi(Ad, MAX_LOG_CONDITION) if n else None
    checked = by_eig is None and n > 0
    if checked:
        # beyond the a priori bound: kept only when exact enough a posteriori
        by_eig = _log_and_phi(Ad, CHECKED_LOG_CONDITION)
    if by_eig is not None:
        log_ad, phi_ad = by_eig
        L = np.hstack([log_ad, phi_ad @ np.hstack([Bd, Kd])])
        if checked and not _reproduces(L.real, M):
            L = None
    if L is None:
        with warnings.catch_warnings():
            # logm warns about its own accuracy estimate; accuracy is checked below instead
            warnings.simplefilter("ignore", RuntimeWarning)
            L = np.asarray(logm(M))[:n]
    if np.iscomplexobj(L):
        imag = float(np.max(np.abs(L.imag))) if L.size else 0.0
        if imag > 1e-8 * max(1.0, float(np.max(np.abs(L.real)))):
            warnings.warn(
                f"d2c: the matrix logarithm has an imaginary part of size {imag:.3g}; "
                f"the continuous model is unreliable (eigenvalues of Ad near the negative "
                f"real axis)",
                RuntimeWarning,
                stacklevel=user_stacklevel(),
            )
        L = L.real
    L = L / dt
    return L[:, :n], L[:, n : n + m], C.copy(), D.copy(), L[:, n + m :]
