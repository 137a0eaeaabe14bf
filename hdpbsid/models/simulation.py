"""The sampled system over a record's steps: what simulation and prediction share.

A continuous-time model is simulated exactly at arbitrary times ``t``: each step
``h = t_{k+1} - t_k`` has its own one-step matrices from the exponential of an augmented
matrix (Franklin, Powell & Workman, *Digital Control of Dynamic Systems*, 3rd ed.,
sec. 6.3; :func:`hdpbsid.models.conversion.sampled_steps`).  Steps equal to 1e-12
relative share one exponential (:func:`step_groups`), so a uniform record needs one.
The recursions themselves live with the model (:class:`~hdpbsid.models.model.StateSpaceModel`);
here are the checks of the signals, the input's contribution to each step, the free
responses and the least-squares initial state.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from hdpbsid.data.checks import (
    as_float_array,
    check_signal,
    check_time,
    check_uniform,
    is_uniform,
    scale_exponents,
)
from hdpbsid.models.conversion import sampled_steps
from hdpbsid.models.dead_time import delayed_input_terms

if TYPE_CHECKING:
    from hdpbsid.models.model import StateSpaceModel

__all__ = [
    "step_groups",
    "initial_state",
    "output_weights",
    "check_input",
    "check_x0",
    "check_output",
    "step_matrices",
    "input_terms",
    "input_steps",
    "forced_and_free",
]

Array = NDArray[np.float64]


def output_weights(y: Array) -> Array:
    """Weights ``1 / std(y_i)`` that put every output of ``y`` on the same scale.

    The initial state fitted to several outputs at once is a least-squares compromise
    between them; unweighted, an output measured in small units (a rate in rad/s beside
    an acceleration in m/s^2) barely enters it, and its own errors grow by what the
    initial state does for the others.  With each output divided by its own spread the
    fit is the same in any units, the normalisation of the fit statistics
    (``NRMSE``, MATLAB's ``fit``) and of the held-out scores
    (:mod:`hdpbsid.models.criteria`).

    Parameters
    ----------
    y : ndarray, shape (Ns, l)
        The outputs (deviations or absolute: the spread is about each output's mean).

    Returns
    -------
    ndarray, shape (l,)
        ``1 / std(y_i)``; an output with no spread (or not finite) keeps weight 1.

    Examples
    --------
    >>> output_weights(np.array([[0.0, 0.0], [2.0, 0.02]]))
    array([  1., 100.])
    """
    with np.errstate(invalid="ignore", over="ignore"):
        s = np.std(np.asarray(y, dtype=float), axis=0)
    ok = np.isfinite(s) & (s > 0.0)
    return np.where(ok, 1.0 / np.where(ok, s, 1.0), 1.0)


def initial_state(O: Array, r: Array, weights: Array | None = None) -> Array:
    """Least-squares ``x0`` of ``O x0 ~ r``, the rows weighted per output.

    Parameters
    ----------
    O : ndarray, shape (q, n)
        The free responses from each unit initial state, stacked: row ``j l + i`` is
        output ``i`` at sample ``j`` (a ``(Ns, l)`` response raveled).
    r : ndarray, shape (q,)
        What the initial state has to explain, in the same order.
    weights : ndarray, shape (l,), optional
        Weight of each output's rows (:func:`output_weights`: the fit independent of
        the outputs' units); default 1.

    Returns
    -------
    ndarray, shape (n,)
        The least-squares initial state.

    Raises
    ------
    numpy.linalg.LinAlgError
        When ``O`` or ``r`` is not finite (the free response of a diverging model or
        predictor): the least-squares problem has no solution.

    Notes
    -----
    ``O`` and ``r`` are scaled by powers of two (exact) to unit size first: the solver
    forms norms (sums of squares), which for a record in extreme units (1e-200, 1e200)
    underflow or overflow.  Non-finite data never reach LAPACK: its scaling routine
    rejects them with a message printed on the process's standard output (which a
    library must not emit) before the solver raises the same error.

    Examples
    --------
    >>> initial_state(np.array([[1.0], [2.0]]), np.array([1.0, 2.0]))
    array([1.])
    """
    if not (np.all(np.isfinite(O)) and np.all(np.isfinite(r))):
        raise np.linalg.LinAlgError("initial_state: the free response is not finite")
    if weights is not None and r.size:
        w = np.tile(np.asarray(weights, dtype=float), r.size // np.size(weights))
        O, r = O * w[:, None], r * w
    po = int(scale_exponents(O.ravel(), "O")[0]) if O.size else 0
    pr = int(scale_exponents(r, "r")[0]) if r.size else 0
    x = np.linalg.lstsq(np.ldexp(O, po), np.ldexp(r, pr), rcond=None)[0]
    return np.ldexp(x, po - pr)


def step_groups(t: Array) -> tuple[Array, Array, Array]:
    """The steps of ``t`` grouped by size.

    Parameters
    ----------
    t : ndarray, shape (Ns,)
        Strictly increasing sample times.

    Returns
    -------
    h : ndarray, shape (Ns - 1,)
        The steps ``diff(t)``.
    h_groups : ndarray, shape (g,)
        One representative per group of steps equal to 1e-12 relative.
    inv : ndarray of int, shape (Ns - 1,)
        Each step's group index (``h ~ h_groups[inv]``).

    Notes
    -----
    A uniformly sampled ``t`` (:func:`~hdpbsid.data.checks.check_uniform`: spacing equal
    to 1e-6 relative plus the stamps' own rounding) is one group with the mean spacing:
    ``arange(Ns) * dt`` has steps that differ in their last bits, which would otherwise
    split it into several groups and the recursions into a loop over the samples.
    """
    h = np.diff(t)
    if h.size > 1 and is_uniform(t):
        return h, np.array([check_uniform(t)]), np.zeros(h.size, dtype=np.intp)
    key = np.round(h / np.max(h), 12)
    _, first, inv = np.unique(key, return_index=True, return_inverse=True)
    return h, h[first], inv.reshape(-1)


def check_input(model: StateSpaceModel, t: Any, u: Any, method: str) -> tuple[Array, Array]:
    """The checked times and input of a simulation.

    Parameters
    ----------
    model : StateSpaceModel
        The model (its input count).
    t : array_like, shape (Ns,)
        Strictly increasing sample times.
    u : array_like, shape (Ns, m) or None
        The input; ``None`` for a model without inputs.
    method : str
        The input hold, ``"zoh"`` or ``"foh"``.

    Returns
    -------
    t : ndarray, shape (Ns,)
        The times.
    u : ndarray, shape (Ns, m)
        The input.

    Raises
    ------
    ValueError
        If ``method`` is unknown, ``t`` is not strictly increasing or ``u`` has the wrong
        shape.
    """
    if method not in ("zoh", "foh"):
        raise ValueError(f"method must be 'zoh' or 'foh', got {method!r}")
    t = check_time(t, "t", min_samples=1)
    if model.m == 0 and u is None:
        u = np.zeros((t.shape[0], 0))
    u = check_signal(u, "u", t.shape[0], limit_energy=False)
    if u.shape[1] != model.m:
        raise ValueError(f"u must have {model.m} column(s) (inputs), got shape {u.shape}")
    return t, u


def check_x0(model: StateSpaceModel, x0: Any | None) -> Array:
    """The initial deviation state: zeros when ``None``.

    Parameters
    ----------
    model : StateSpaceModel
        The model (its state dimension).
    x0 : array_like, shape (n,), or None
        The state given.

    Returns
    -------
    ndarray, shape (n,)
        The state.

    Raises
    ------
    ValueError
        If ``x0`` has the wrong length.
    """
    x = np.zeros(model.n) if x0 is None else as_float_array(x0, "x0").reshape(-1)
    if x.shape[0] != model.n:
        raise ValueError(f"x0 must have {model.n} entries (the state dimension), got {x.shape[0]}")
    return x


def check_output(model: StateSpaceModel, t: Array, y: Any) -> Array:
    """The checked measured output of a record.

    Parameters
    ----------
    model : StateSpaceModel
        The model (its output count).
    t : ndarray, shape (Ns,)
        The checked times.
    y : array_like, shape (Ns, l)
        The output.

    Returns
    -------
    ndarray, shape (Ns, l)
        The output.

    Raises
    ------
    ValueError
        If ``y`` has the wrong shape.
    """
    y = check_signal(y, "y", t.shape[0], limit_energy=False)
    if y.shape[1] != model.l:
        raise ValueError(f"y must have {model.l} column(s) (outputs), got shape {y.shape}")
    return y


def step_matrices(
    model: StateSpaceModel, h: Array, method: str, with_k: bool = False
) -> tuple[Array, Array, Array | None, Array | None]:
    """Exact one-step matrices ``(Phi, G1, G2, Gk)`` of ``model`` for the steps ``h``.

    Parameters
    ----------
    model : StateSpaceModel
        The model.
    h : ndarray, shape (g,)
        The steps.
    method : str
        The input hold, ``"zoh"`` or ``"foh"``.
    with_k : bool, optional
        Also the innovation's matrix ``Gk``.

    Returns
    -------
    tuple of ndarray
        ``Phi (g, n, n)``; ``G1`` multiplies ``u_k``; ``G2`` (FOH only, else ``None``)
        multiplies ``u_{k+1} - u_k``; ``Gk`` (``with_k`` only, else ``None``) multiplies
        the innovation held over the step, the hold convention of
        :mod:`hdpbsid.models.conversion` (:func:`~hdpbsid.models.conversion.sampled_steps`).

    Notes
    -----
    From the augmented exponentials (Franklin, Powell & Workman, *Digital Control*,
    sec. 6.3): ``expm([[A h, B h, 0, K h], [0, 0, I, 0], [0, 0, 0, 0], [0, 0, 0, 0]])``.
    """
    return sampled_steps(model.A, model.B, model.K if with_k else None, h, method)


def input_terms(
    model: StateSpaceModel,
    t: Array,
    u: Array,
    method: str,
    Phi: Array,
    G1: Array,
    G2: Any,
    inv: Array,
) -> tuple[Array, Array]:
    """The input's contribution to each step, and the input the direct term sees.

    Parameters
    ----------
    model : StateSpaceModel
        The model.
    t : ndarray, shape (Ns,)
        The times, ``Ns >= 2``.
    u : ndarray, shape (Ns, m)
        The deviation input.
    method : str
        The input hold, ``"zoh"`` or ``"foh"``.
    Phi, G1, G2 : ndarray
        The one-step matrices of the step groups (:func:`step_matrices`).
    inv : ndarray of int, shape (Ns - 1,)
        Each step's group.

    Returns
    -------
    Bu : ndarray, shape (Ns - 1, n)
        ``G1 u_k (+ G2 (u_{k+1} - u_k))`` per step.
    ud : ndarray, shape (Ns, m)
        ``u`` itself, or ``u`` at ``t - delay`` with a dead time
        (:func:`hdpbsid.models.dead_time.delayed_input_terms`).
    """
    if model.has_delay:
        return delayed_input_terms(model.A, model.B, t, u, model.delay, method, Phi, inv)
    Bu = np.einsum("kij,kj->ki", G1[inv], u[:-1])
    if G2 is not None:
        Bu += np.einsum("kij,kj->ki", G2[inv], np.diff(u, axis=0))
    return Bu, u


def input_steps(
    model: StateSpaceModel, t: Array, u: Array, method: str
) -> tuple[Array, Array, Array, Array]:
    """The sampled system over the steps of ``t`` (``Ns >= 2``).

    Parameters
    ----------
    model : StateSpaceModel
        The model.
    t : ndarray, shape (Ns,)
        The times.
    u : ndarray, shape (Ns, m)
        The deviation input.
    method : str
        The input hold, ``"zoh"`` or ``"foh"``.

    Returns
    -------
    Phi : ndarray, shape (g, n, n)
        The distinct one-step matrices.
    inv : ndarray of int, shape (Ns - 1,)
        Each step's group, so that ``x_{k+1} = Phi[inv[k]] x_k + Bu[k]``.
    Bu, ud : ndarray
        The input terms of :func:`input_terms`.
    """
    _, hg, inv = step_groups(t)
    Phi, G1, G2, _ = step_matrices(model, hg, method)
    Bu, ud = input_terms(model, t, u, method, Phi, G1, G2, inv)
    return Phi, inv, Bu, ud


def forced_and_free(model: StateSpaceModel, t: Array, u: Array, method: str) -> tuple[Array, Array]:
    """The forced response and the free responses from each unit state, in one pass.

    Parameters
    ----------
    model : StateSpaceModel
        The model.
    t : ndarray, shape (Ns,)
        The times.
    u : ndarray, shape (Ns, m)
        The deviation input.
    method : str
        The input hold, ``"zoh"`` or ``"foh"``.

    Returns
    -------
    y : ndarray, shape (Ns, l)
        The response to ``u`` from the zero state.
    O : ndarray, shape (Ns l, n)
        The free responses, so that ``y + (O x0).reshape(Ns, l)`` is the response from
        ``x0``.

    Notes
    -----
    The step matrices of a non-uniform ``t`` are computed once for all ``n + 1``
    responses.
    """
    ns, n = t.shape[0], model.n
    S = np.zeros((ns, n, n + 1))  # column 0: forced; columns 1..n: free from e_j
    S[0, :, 1:] = np.eye(n)
    ud = u
    if ns > 1:
        Phi, inv, Bu, ud = input_steps(model, t, u, method)
        z = S[0]
        for k in range(ns - 1):
            z = Phi[inv[k]] @ z
            z[:, 0] += Bu[k]
            S[k + 1] = z
    Y = np.einsum("li,kij->klj", model.C, S)
    return Y[:, :, 0] + ud @ model.D.T, Y[:, :, 1:].reshape(ns * model.l, n)
