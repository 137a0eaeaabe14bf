"""Modes that are a drift of the record, not modes of the plant (:func:`drift_modes`).

A state-space model of order ``n`` can spend a state on what the record carries besides
the plant's response to the input: an output offset or a slow trend that each window's
fitted initial state, or the noise model, turns into a better fit.  Such a mode is not
a mode of the plant, and an order that adds one is not the plant's order.  A mode is
counted as a drift when both hold:

* it is slower than the record resolves, ``|lambda| T < 2 pi`` (``T`` the record's
  span): over the record it completes less than a period, or decays by less than
  ``e^{-2 pi}``, so its free response is not told apart from an offset or a trend
  (the record's frequency resolution, ``2 pi / T``);
* the input does not drive it above the noise: the part of the output the input
  drives through that mode (its modal input-output path, from a zero state) has, in
  every output, a root mean square below that of the model's one-step prediction
  errors on the record.  A plant mode as slow, an integrator for one, carries the
  input's effect on the output: its input-driven part is large, and it is not
  counted.

Only the decision between orders asks this (:mod:`hdpbsid.selection.rejudge`); the
eigenvalues and the modal paths are those of the model's continuous-time ``A``,
``B``, ``C``, sampled exactly for a held input (for a mode this slow the hold
between samples makes no difference: ``|lambda| h << 1``).
"""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np
from scipy.signal import lfilter

from hdpbsid.models.model import StateSpaceModel
from hdpbsid.models.recursion import modal_form

__all__ = ["drift_modes", "input_driven_rms", "undriven_modes"]


def input_driven_rms(
    model: StateSpaceModel, t: Any, u: Any
) -> tuple[np.ndarray, np.ndarray] | None:
    r"""The eigenvalues of ``model`` and, for each, the root mean square over the record
    of the output the input drives through that mode.

    With :math:`A = V \Lambda V^{-1}`, mode :math:`i` obeys
    :math:`\dot z_i = \lambda_i z_i + w_i^T B u` (:math:`w_i^T` the row :math:`i` of
    :math:`V^{-1}`) and adds :math:`(C v_i) z_i` to the output; sampled exactly for an
    input held over each step :math:`h`,
    :math:`z_{k+1} = e^{\lambda_i h} z_k + \frac{e^{\lambda_i h} - 1}{\lambda_i} w_i^T B
    u_k`, from :math:`z_0 = 0`, with the input's mean removed (a level carries no
    dynamics).  A complex pair adds :math:`2 \operatorname{Re}((C v_i) z_i)`, its real
    contribution, reported for each member.

    Parameters
    ----------
    model : StateSpaceModel
        The model (continuous time).
    t : array_like
        Uniform sample times, ``(Ns,)``.
    u : array_like
        Inputs, ``(Ns, m)``.

    Returns
    -------
    tuple of (ndarray, ndarray) or None
        The eigenvalues ``(n,)`` and the root mean squares ``(n, l)``; None when the
        model has no input or its ``A`` is nearly defective
        (:func:`~hdpbsid.models.recursion.modal_form`: no modal paths to speak of).

    Examples
    --------
    >>> import numpy as np
    >>> from hdpbsid import StateSpaceModel
    >>> m = StateSpaceModel([[-1.0]], [[1.0]], [[1.0]], [[0.0]], [[0.0]])
    >>> t = np.arange(0.0, 200.0, 0.01)
    >>> lam, rms = input_driven_rms(m, t, np.sin(t)[:, None])
    >>> round(float(rms[0, 0]), 2)  # |1 / (j + 1)| / sqrt(2): sin t through 1 / (s + 1)
    0.5
    """
    t = np.asarray(t, dtype=float)
    u = np.asarray(u, dtype=float).reshape(t.size, -1)
    if u.shape[1] == 0 or model.n == 0:
        return None
    modes = modal_form(np.asarray(model.A, dtype=float))
    if modes is None:
        return None
    lam, V, W = modes
    h = float(np.median(np.diff(t)))
    drive = (u - u.mean(axis=0)) @ (W @ np.asarray(model.B, dtype=float)).T
    out = np.empty((lam.size, model.C.shape[0]))
    with np.errstate(all="ignore"):
        for i, li in enumerate(lam):
            a = np.exp(li * h)
            gain = (a - 1.0) / li if abs(li * h) > 1e-12 else h
            z = lfilter([0.0, gain], [1.0, -a], drive[:, i])
            y = np.outer(z, np.asarray(model.C, dtype=float) @ V[:, i])
            y = 2.0 * y.real if abs(li.imag) > 0 else y.real
            out[i] = np.sqrt(np.mean(y**2, axis=0))
    return lam, out


def undriven_modes(model: StateSpaceModel, rec: tuple) -> np.ndarray | None:
    """Which modes of ``model`` the input of the record ``rec = (t, u, y)`` drives, in
    every output, less than the noise: the root mean square of the output it drives
    through the mode (:func:`input_driven_rms`) below that of the model's one-step
    prediction errors on the record.

    Such a mode adds less to the output's response to the input than the noise the
    record carries, at any of its samples' scales: the record holds no evidence of it
    as a mode of the input-output system.  It is what a state spent on a drift of the
    record (:func:`drift_modes`), on the noise model alone, or on an artefact of a
    local minimum of the prediction error (a lightly damped pair near the Nyquist
    frequency, a real mode far beyond the input's band) looks like.

    Parameters
    ----------
    model : StateSpaceModel
        The model (continuous time).
    rec : tuple
        The uniformly sampled record ``(t, u, y)`` it is judged on.

    Returns
    -------
    ndarray of bool or None
        ``(n,)``, in the order of :func:`input_driven_rms`'s eigenvalues; None when it
        cannot be judged (no input, a nearly defective ``A``, a one-step predictor that
        diverges on the record).

    Examples
    --------
    >>> import numpy as np
    >>> from hdpbsid import StateSpaceModel
    >>> t = np.arange(0.0, 100.0, 0.01)
    >>> u = np.sign(np.sin(2.0 * t))[:, None]
    >>> m = StateSpaceModel([[-1.0, 0.0], [0.0, -3.0]], [[1.0], [1e-4]], [[1.0, 1.0]],
    ...                     [[0.0]], [[0.0], [0.0]])
    >>> rng = np.random.default_rng(0)
    >>> y = m.simulate(t, u) + 0.1 * rng.standard_normal((t.size, 1))
    >>> undriven_modes(m, (t, u, y)).tolist()  # the second mode's input path is 1e-4
    [False, True]
    """
    found = _undriven(model, rec)
    return None if found is None else found[1]


def _undriven(model: StateSpaceModel, rec: tuple) -> tuple[np.ndarray, np.ndarray] | None:
    """The eigenvalues of ``model`` and :func:`undriven_modes`'s mask, or None."""
    from hdpbsid.refine.pem import one_step_errors

    t, u, y = rec
    t = np.asarray(t, dtype=float)
    if u is None:
        return None
    paths = input_driven_rms(model, t, u)
    with warnings.catch_warnings(), np.errstate(all="ignore"):
        warnings.simplefilter("ignore")
        try:
            errors = one_step_errors(model, t, u, y)
        except (ValueError, np.linalg.LinAlgError):
            errors = None
    if paths is None or errors is None or not np.all(np.isfinite(errors)):
        return None
    noise = np.sqrt(np.mean(np.asarray(errors) ** 2, axis=0))
    return paths[0], np.all(paths[1] < noise, axis=1)


def drift_modes(model: StateSpaceModel, rec: tuple) -> int:
    """The number of modes of ``model`` that are a drift of the record ``rec = (t, u, y)``
    (module docstring): slower than ``2 pi / T`` and driven by the input, in every
    output, less than the one-step prediction errors' root mean square.

    Parameters
    ----------
    model : StateSpaceModel
        The model.
    rec : tuple
        The uniformly sampled record ``(t, u, y)`` it is judged on.

    Returns
    -------
    int
        The number of such modes; 0 when it cannot be judged (no input, a nearly
        defective ``A``, a one-step predictor that diverges on the record).
    """
    t = np.asarray(rec[0], dtype=float)
    span = float(np.ptp(t))
    slow = np.abs(np.linalg.eigvals(np.asarray(model.A, dtype=float))) * span < 2 * np.pi
    if rec[1] is None or not np.any(slow):
        return 0
    found = _undriven(model, rec)
    if found is None:
        return 0
    lam, undriven = found
    return int(np.sum((np.abs(lam) * span < 2 * np.pi) & undriven))
