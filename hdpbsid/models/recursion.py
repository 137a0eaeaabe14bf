"""Linear state recursions ``x_{k+1} = F x_k + w_k`` run as modal first-order filters.

A Python loop over the samples costs about 5 us a step (0.2 s for 10^4 samples of a
k-step predictor evaluated three times); the same recursion diagonalised,
``F = V diag(lam) V^{-1}``, ``z = V^{-1} x``, is ``n`` independent first-order filters
``z_{a,k+1} = lam_a z_{a,k} + (V^{-1} w_k)_a`` run by :func:`scipy.signal.lfilter` in
compiled code.  Rounding: the change of coordinates multiplies the rounding error by at
most ``cond(V)`` (Higham, *Accuracy and Stability of Numerical Algorithms*, 2nd ed.,
ch. 7), so :func:`linear_recursion` falls back to the loop when ``cond(V)`` exceeds
:data:`MAX_MODAL_CONDITION` (nearly defective ``F``).

With numba installed (and ``SLBASIS_NO_NUMBA`` unset) the loop itself runs compiled
(:mod:`hdpbsid.models.recursion_kernels`), about 20 times faster than the modal filters on the
short windows of the held-out scores and without their rounding amplification; the
modal filters are then the fallback (``engine="numpy"``).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray

from slbasis.numeric import jit
from slbasis.numeric.engine import numba_available

__all__ = [
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

#: largest eigenvector condition number for the modal form: rounding errors of order
#: cond(V) * 1e-16 stay below 1e-10 relative, far below any noise the data carry
MAX_MODAL_CONDITION = 1e6
#: the evaluations of hdpbsid's passes over the samples (these recursions, the
#: refinement's predictor): ``"numba"`` compiled, ``"numpy"`` without numba (here the
#: modal filters, or the loop in numpy when ``F`` is nearly defective), ``"auto"`` the
#: first when numba can be used
ENGINES = ("auto", "numpy", "numba")


def select_kernels(engine: str, load: Callable[[], Any]) -> Any:
    """The compiled-kernel module ``load()`` returns, for ``engine`` (:data:`ENGINES`), or
    None for the numpy evaluation; ``load`` raises ``ImportError`` for
    ``engine="numba"`` without numba."""
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
    """``z_{k+1} = lam_a z_k + R[..., a, k]`` from ``z_0 = 0`` for every eigenvalue ``a``.

    ``R`` has shape ``(..., n, Ns)``; the output has the same shape (complex),
    ``z[..., 0] = 0``.  A real eigenvalue is filtered in real arithmetic when its row of
    ``R`` is real.
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
    """``(lam, V, V^{-1})`` with ``F = V diag(lam) V^{-1}`` when the eigenvectors are
    finite with ``cond(V) <= max_condition`` (module docstring), else None."""
    with np.errstate(all="ignore"):
        if not np.all(np.isfinite(F)):
            return None
        lam, V = np.linalg.eig(F)
        if not (np.all(np.isfinite(V)) and np.linalg.cond(V) <= max_condition):
            return None
        return lam, V, np.linalg.inv(V)


def forced_responses(F: Array, W: Array, engine: str = "auto") -> Array:
    """A batch of recursions from a zero state: ``X[b, 0] = 0``,
    ``X[b, k + 1] = F X[b, k] + W[b, k]``.

    ``F (n, n)`` real, ``W (B, K, n)``; returns ``X (B, K + 1, n)``.  The compiled loop
    (``engine``, module docstring); without it, modal filters over the whole batch at
    once when ``F`` is well diagonalisable, else the plain loop over ``k`` (vectorised
    over the batch).  Growing modes may overflow to ``inf``, as they would in the loop.
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
    """``P[k] = F^k`` for ``k = 0 .. K - 1``, shape ``(K, n, n)``: repeated products,
    compiled (``engine``, module docstring); without them ``V diag(lam^k) V^{-1}`` when
    ``F`` is well diagonalisable, else repeated products in numpy."""
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
    """States ``x_0 = x0``, ``x_{k+1} = F x_k + W[k]`` for ``k = 0 .. len(W) - 1``.

    ``F (n, n)`` real, ``W (Ns - 1, n)``, ``x0 (n,)``; returns ``X (Ns, n)``.  The
    compiled loop (``engine``, module docstring); without it, modal filters when ``F``
    is diagonalisable with ``cond(V) <= MAX_MODAL_CONDITION``, else the plain loop (the
    oracle of the tests).
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
