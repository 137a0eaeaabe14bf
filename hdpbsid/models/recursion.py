"""Linear state recursions ``x_{k+1} = F x_k + w_k`` run as modal first-order filters.

A Python loop over the samples pays the interpreter's overhead at every step, which
dominates for the small ``n`` of identified models; the same recursion diagonalised,
``F = V diag(lam) V^{-1}``, ``z = V^{-1} x``, is ``n`` independent first-order filters
``z_{a,k+1} = lam_a z_{a,k} + (V^{-1} w_k)_a`` run by :func:`scipy.signal.lfilter` in
compiled code.  Rounding: the change of coordinates multiplies the rounding error by at
most ``cond(V)`` (Higham, *Accuracy and Stability of Numerical Algorithms*, 2nd ed.,
ch. 7), so :func:`linear_recursion` falls back to the loop when ``cond(V)`` exceeds
:data:`MAX_MODAL_CONDITION` (nearly defective ``F``).

With numba installed (and ``SLBASIS_NO_NUMBA`` unset) the loop itself runs compiled
(:mod:`hdpbsid.models.recursion_kernels`): ``n^2`` multiply-adds a step without the
filters' per-call overhead, which dominates on the short windows of the held-out scores,
and without their rounding amplification; the modal filters are then the fallback
(``engine="numpy"``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from slbasis.numeric import jit
from slbasis.numeric.engine import numba_available

__all__ = [
    "RecursionSettings",
    "RECURSION",
    "modal_filter",
    "linear_recursion",
    "forced_responses",
    "matrix_powers",
    "modal_form",
    "select_kernels",
    "MAX_MODAL_CONDITION",
    "ENGINES",
]

Array = NDArray[np.float64]

# compiled ahead of their first use, in the background, by slbasis.numeric.jit
jit.register("hdpbsid.models.recursion_kernels", "hdpbsid.refine.pem_kernels")


@dataclass(frozen=True)
class RecursionSettings:
    """When the recursion takes the modal route.

    Attributes
    ----------
    max_modal_condition : float
        Largest eigenvector condition number for the modal form.
    """

    #: largest eigenvector condition number for the modal form: rounding errors of order
    #: cond(V) * 1e-16 stay below 1e-10 relative, far below any noise the data carry
    max_modal_condition: float = 1e6


#: The settings in force.
RECURSION = RecursionSettings()
#: :attr:`RecursionSettings.max_modal_condition` of :data:`RECURSION`
MAX_MODAL_CONDITION = RECURSION.max_modal_condition
#: the evaluations of hdpbsid's passes over the samples (these recursions, the
#: refinement's predictor): ``"numba"`` compiled, ``"numpy"`` without numba (here the
#: modal filters, or the loop in numpy when ``F`` is nearly defective), ``"auto"`` the
#: first when numba can be used
ENGINES = ("auto", "numpy", "numba")


def select_kernels(engine: str, load: Callable[[], Any]) -> Any:
    """The compiled-kernel module to use for an engine, or ``None`` for numpy.

    Parameters
    ----------
    engine : {"auto", "numpy", "numba"}
        :data:`ENGINES`: ``"auto"`` uses the compiled kernels when numba can be used and
        they are compiled (numpy while they compile in the background,
        :mod:`slbasis.numeric.jit`).
    load : callable
        Returns the kernel module; raises ``ImportError`` for ``engine="numba"`` without
        numba.

    Returns
    -------
    module or None
        The kernel module, or ``None`` for the numpy evaluation.

    Raises
    ------
    ValueError
        If ``engine`` is not one of :data:`ENGINES`.
    ImportError
        From ``load`` when ``engine="numba"`` and numba is missing.
    """
    if engine not in ENGINES:
        raise ValueError(f"engine must be one of {ENGINES}, got {engine!r}")
    if engine == "numpy" or (engine == "auto" and not numba_available()):
        return None
    module = load()
    if engine == "auto" and not jit.ready(module):
        return None  # numpy while the kernels compile in the background (slbasis.numeric.jit)
    return module


def _load_kernels() -> Any:
    import hdpbsid.models.recursion_kernels as kernels

    return kernels


def _kernels(engine: str) -> Any:
    """The recursions' compiled kernels for ``engine`` (None: the numpy evaluation)."""
    return select_kernels(engine, _load_kernels)


def modal_filter(lam: NDArray[np.complex128], R: NDArray) -> NDArray:
    """First-order recursions ``z_{k+1} = lam_a z_k + R[..., a, k]`` from ``z_0 = 0``.

    Parameters
    ----------
    lam : ndarray of complex, shape (n,)
        The eigenvalues, one filter each.
    R : ndarray, shape (..., n, Ns)
        The drive of each filter (real or complex).

    Returns
    -------
    ndarray of complex, shape (..., n, Ns)
        ``z`` with ``z[..., 0] = 0``.  A real eigenvalue is filtered in real arithmetic when
        its row of ``R`` is real (:func:`scipy.signal.lfilter`).
    """
    from scipy.signal import lfilter  # here: scipy.signal costs a third of a second to import

    Z = np.zeros(R.shape, dtype=complex)
    for a in range(lam.size):
        ra = R[..., a, :-1]
        if lam[a].imag == 0 and not np.any(np.imag(ra)):
            Z[..., a, 1:] = lfilter([1.0], [1.0, -lam[a].real], np.real(ra), axis=-1)
        else:
            Z[..., a, 1:] = lfilter([1.0], [1.0, -lam[a]], ra, axis=-1)
    return Z


def modal_form(
    F: Array, max_condition: float = MAX_MODAL_CONDITION
) -> tuple[NDArray, NDArray, NDArray] | None:
    r"""The eigendecomposition of ``F`` when it is well conditioned.

    Parameters
    ----------
    F : ndarray, shape (n, n)
        The recursion matrix.
    max_condition : float, optional
        Largest accepted :math:`\operatorname{cond}(V)`; rounding of a change of
        coordinates grows by at most that factor (Higham, *Accuracy and Stability of
        Numerical Algorithms*, 2nd ed., 2002, ch. 7).

    Returns
    -------
    tuple (lam, V, Vinv) or None
        :math:`F = V \operatorname{diag}(\lambda) V^{-1}` when ``F`` and ``V`` are finite
        and :math:`\operatorname{cond}(V) \le` ``max_condition``, else ``None`` (a nearly
        defective ``F``).

    Examples
    --------
    >>> import numpy as np
    >>> lam, V, Vi = modal_form(np.array([[0.5, 1.0], [0.0, 0.25]]))
    >>> bool(np.allclose(V @ np.diag(lam) @ Vi, [[0.5, 1.0], [0.0, 0.25]]))
    True
    >>> modal_form(np.array([[0.5, 1.0], [0.0, 0.5]])) is None  # a Jordan block
    True
    """
    with np.errstate(all="ignore"):
        if not np.all(np.isfinite(F)):
            return None
        lam, V = np.linalg.eig(F)
        if not (np.all(np.isfinite(V)) and np.linalg.cond(V) <= max_condition):
            return None
        return lam, V, np.linalg.inv(V)


def forced_responses(F: Array, W: Array, engine: str = "auto") -> Array:
    """A batch of recursions from a zero state.

    Parameters
    ----------
    F : ndarray, shape (n, n)
        Real recursion matrix.
    W : ndarray, shape (B, K, n)
        The drives of ``B`` recursions of ``K`` steps.
    engine : {"auto", "numpy", "numba"}, optional
        The compiled loop (module docstring); without it, modal filters over the whole
        batch at once when ``F`` is well diagonalisable, else the plain loop over ``k``
        (vectorised over the batch).

    Returns
    -------
    ndarray, shape (B, K + 1, n)
        ``X[b, 0] = 0``, ``X[b, k + 1] = F X[b, k] + W[b, k]``.  Growing modes may overflow
        to ``inf``, as they would in the loop.
    """
    F = np.asarray(F, dtype=float)
    W = np.asarray(W, dtype=float)
    B, K, n = W.shape
    kernels = _kernels(engine)
    if kernels is not None and n:
        X = np.empty((B, K + 1, n))
        kernels.recursions(np.ascontiguousarray(F), np.ascontiguousarray(W), np.zeros((B, n)), X)
        return X
    modal = modal_form(F) if n else None
    if modal is not None:
        lam, V, Vi = modal
        R = np.zeros((B, n, K + 1), dtype=complex)
        R[:, :, :K] = np.einsum("ij,bkj->bik", Vi, W)
        with np.errstate(over="ignore", invalid="ignore"):
            Z = modal_filter(lam, R)
            return np.real(np.einsum("ij,bjk->bki", V, Z))
    X = np.zeros((B, K + 1, n))
    with np.errstate(over="ignore", invalid="ignore"):
        for k in range(K):
            X[:, k + 1] = X[:, k] @ F.T + W[:, k]
    return X


def matrix_powers(F: Array, K: int, engine: str = "auto") -> Array:
    r"""The powers ``P[k] = F^k`` for ``k = 0 .. K - 1``.

    Parameters
    ----------
    F : ndarray, shape (n, n)
        Real matrix.
    K : int
        Number of powers.
    engine : {"auto", "numpy", "numba"}, optional
        Repeated products, compiled (module docstring); without them
        :math:`V \operatorname{diag}(\lambda^k) V^{-1}` when ``F`` is well
        diagonalisable, else repeated products in numpy.

    Returns
    -------
    ndarray, shape (K, n, n)
        The powers.

    Examples
    --------
    >>> import numpy as np
    >>> P = matrix_powers(np.array([[0.0, 1.0], [0.0, 0.0]]), 3, engine="numpy")
    >>> P[2].tolist()  # nilpotent: F^2 = 0
    [[0.0, 0.0], [0.0, 0.0]]
    """
    F = np.asarray(F, dtype=float)
    n = F.shape[0]
    kernels = _kernels(engine)
    if kernels is not None and n:
        P = np.empty((K, n, n))
        kernels.powers(np.ascontiguousarray(F), P)
        return P
    modal = modal_form(F) if n else None
    if modal is not None:
        lam, V, Vi = modal
        with np.errstate(over="ignore", invalid="ignore"):
            powers = lam[None, :] ** np.arange(K)[:, None]  # (K, n)
            return np.real(np.einsum("ia,ka,aj->kij", V, powers, Vi))
    P = np.empty((K, n, n))
    Pk = np.eye(n)
    with np.errstate(over="ignore", invalid="ignore"):
        for k in range(K):
            P[k] = Pk
            Pk = F @ Pk
    return P


def linear_recursion(F: Array, W: Array, x0: Array, engine: str = "auto") -> Array:
    r"""States of ``x_{k+1} = F x_k + W[k]`` from ``x_0 = x0``.

    Parameters
    ----------
    F : ndarray, shape (n, n)
        Real recursion matrix.
    W : ndarray, shape (Ns - 1, n)
        The drive.
    x0 : ndarray, shape (n,)
        Initial state.
    engine : {"auto", "numpy", "numba"}, optional
        The compiled loop (module docstring); without it, modal filters when ``F`` is
        diagonalisable with :math:`\operatorname{cond}(V) \le`
        :data:`MAX_MODAL_CONDITION`, else the plain loop (the oracle of the tests).

    Returns
    -------
    ndarray, shape (Ns, n)
        ``X[0] = x0``, ``X[k + 1] = F X[k] + W[k]``.

    Examples
    --------
    >>> import numpy as np
    >>> X = linear_recursion(np.array([[0.5]]), np.ones((3, 1)), np.array([0.0]), engine="numpy")
    >>> np.round(X[:, 0], 12).tolist()  # 0, 1, 1.5, 1.75
    [0.0, 1.0, 1.5, 1.75]
    """
    F = np.asarray(F, dtype=float)
    W = np.asarray(W, dtype=float)
    x0 = np.asarray(x0, dtype=float)
    ns, n = W.shape[0] + 1, F.shape[0]
    kernels = _kernels(engine)
    if kernels is not None and n:
        X = np.empty((1, ns, n))
        kernels.recursions(
            np.ascontiguousarray(F),
            np.ascontiguousarray(W.reshape(1, ns - 1, n)),
            np.ascontiguousarray(x0.reshape(1, n)),
            X,
        )
        return X[0]
    if n:
        lam, V = np.linalg.eig(F)
        if np.all(np.isfinite(V)) and np.linalg.cond(V) <= MAX_MODAL_CONDITION:
            Vi = np.linalg.inv(V)
            R = np.zeros((n, ns), dtype=complex)
            R[:, 0] = Vi @ x0  # z_1 = lam z_0 + ..., entered as the drive of step -1
            R[:, 1:] = Vi @ W.T
            # modal_filter starts from 0, so shift by one step: z_k = filtered[k + 1]
            Z = modal_filter(lam, np.concatenate([R, np.zeros((n, 1))], axis=1))[:, 1:]
            return np.real(V @ Z).T
    X = np.empty((ns, n))
    X[0] = x0
    for k in range(ns - 1):
        X[k + 1] = F @ X[k] + W[k]
    return X
