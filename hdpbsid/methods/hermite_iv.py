"""Instrumental variables for HD-PBSID: a consistent basis-domain estimator in closed loop.

Why least squares is biased in the basis domain.  The VARX of HD-PBSID regresses the
output coefficients ``Y`` on ``Z M^j`` (``Z = [U; Y]``, ``M = D'^{-1}`` the integrator lag
of :mod:`hdpbsid.methods.hermite`).  For sampled data the lag is the shift ``S``, strictly
causal: ``(Z S^j)_k`` holds only ``z_{k-j}``, so with white innovations
``E[e_k (e S^j)_k] = 0``.  ``M`` is instead a full matrix with ``diag M != 0``: projected
white noise has (nearly) white coefficients ``E`` with covariance ``sigma^2 I``, and

    E[E (E M^j)^T] = sigma^2 tr(M^j) != 0,

so every regressor ``Y M^j`` (and ``U M^j`` in closed loop, where ``U`` carries the
fed-back noise) is correlated with the equation error and least squares converges to the
wrong predictor.  ``Dd`` is skew-symmetric, so ``M`` has the eigenvalues
``1 / (beta + i omega_k / alpha)`` (``gamma = 1``; ``omega_k`` the frequencies of ``Dd``):
those of the slow basis directions (``|omega_k| << alpha``) are close to one for every
power ``j``, so ``tr(M^j)`` does not decay with ``j`` and instruments taken from "further
in the index past" (``Z M^{p+j}``) are correlated with ``E`` as well.  The bias does not
shrink with more data (it is a property of the operator, not of the sample size).

The remedy here: instruments that are functions of an external signal ``r`` (the
reference or excitation added in the loop), which is independent of the noise.  Its
coefficient row ``R`` (projected like the input, on every block's basis) lagged by the
same operator,

    Psi = [R; R M; R M^2; ...; R M^L],

is uncorrelated with ``E`` for every ``L`` and correlated with the regressors (their
noise-free parts are filtered ``r``).  The pseudo-input rows (boundary and truncation
terms) are deterministic and are their own instruments.  Two-stage least squares on
``Psi`` (:func:`hdpbsid.core.ridge.two_stage_ls`) gives a consistent VARX, and ``C`` is read
from ``Gamma`` (:func:`hdpbsid.core.blocks.pbsid_core_blocks`).  The derivation is in
docs/theory.md ("Closed loop in the basis domain").

What remains.  IV removes the correlation with the noise, not the truncation of the
VARX: ``y = sum_{j<=p} Xi_j z M^j + C At^p x M^p + e``, and the neglected term is a
filtered version of the reference too, so it biases IV as well.  The predictor
eigenvalue ``lambda`` maps to ``lambda / alpha + 1``, of modulus at least
``sqrt(1 - Re(lambda)^2 / |lambda|^2)`` for any ``alpha``: a lightly damped pair contracts
slowly, and a larger ``p`` needs more instruments than the ``N`` coefficients support.
IV also has a larger variance than least squares (in closed loop most of the input's
power is fed-back noise, which the reference does not explain).  That is why the
front end's consistent default is not IV but the prediction-error refinement
(:mod:`hdpbsid.selection.feedback`), which IV can start when the reference is known.

On a simulated closed-loop record with the excitation as ``reference`` (``hdpbsid study
table1``, the benchmark pages), IV moves the bias of the well-damped modes inside their
spread, while a lightly damped pair keeps the truncation bias, and the spread roughly
triples; the prediction-error refinement started from either estimate reaches
nearly the same end points.

Number of lags: two-stage least squares needs at least as many instruments as regressors
that are not their own instruments, ``p (m + l)`` per output; more instruments lower the
variance but move the finite-sample estimate towards least squares (the bias of 2SLS
grows with the number of instruments over the concentration of the instruments; Bound,
Jaeger & Baker 1995).  :data:`INSTRUMENT_FACTOR` sets ``L m_r >= factor * p_max (m + l)``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hdpbsid.core.blocks import BlockLag
from hdpbsid.data.records import Record

__all__ = [
    "ESTIMATORS",
    "INSTRUMENT_FACTOR",
    "check_reference",
    "with_reference",
    "reference_instruments",
]

Array = NDArray[np.float64]

#: accepted values of ``estimator`` of :func:`hdpbsid.methods.hermite.identify_hermite`
ESTIMATORS = ("ls", "iv")


@dataclass(frozen=True)
class InstrumentRule:
    """How many instruments the IV estimator builds (:func:`reference_instruments`).

    Attributes
    ----------
    factor : float
        Instruments per non-exogenous regressor.

    Examples
    --------
    >>> InstrumentRule().factor
    4.0
    """

    #: instruments per non-exogenous regressor (module docstring): with as many
    #: instruments as regressors 2SLS is weakly identified (large spread); a few times
    #: more make the first stage strong, and beyond that the gain is nil while the
    #: finite-sample bias of 2SLS grows with their number (Wooldridge, *Econometric
    #: Analysis*, sec. 5.2)
    factor: float = 4.0


#: instruments per non-exogenous regressor (:attr:`InstrumentRule.factor`)
INSTRUMENT_FACTOR = InstrumentRule().factor


def check_reference(reference: Any, ns: int, name: str = "reference") -> Array:
    """``reference`` as an ``(Ns, m_r)`` finite float array with ``Ns`` rows.

    Parameters
    ----------
    reference : array_like, shape (Ns,) or (Ns, m_r)
        The external signal.
    ns : int
        The record's number of samples.
    name : str, optional
        The argument's name in messages (``reference[i]`` for several records).

    Returns
    -------
    ndarray, shape (Ns, m_r)
        The reference.

    Raises
    ------
    TypeError
        If ``reference`` is not numeric.
    ValueError
        If it has the wrong number of samples, is not finite, or is identically zero (no
        instrument).

    Examples
    --------
    >>> check_reference([1.0, 2.0, 3.0], 3).shape
    (3, 1)
    """
    try:
        r = np.asarray(reference, dtype=float)
    except (TypeError, ValueError) as exc:
        raise TypeError(
            f"{name} must be a numeric array of Ns = {ns} samples, got {type(reference).__name__}"
        ) from exc
    if r.ndim == 1:
        r = r[:, None]
    if r.ndim != 2 or r.shape[0] != ns:
        raise ValueError(
            f"{name} must have Ns = {ns} samples (shape (Ns,) or (Ns, m_r)), got shape {r.shape}"
        )
    if not np.all(np.isfinite(r)):
        raise ValueError(f"{name} must be finite (no NaN/inf)")
    if not np.any(r):
        raise ValueError(f"{name} is identically zero: it cannot serve as an instrument")
    return r


def with_reference(
    records: Sequence[Record], estimator: Any, reference: Any
) -> tuple[list[Record], int]:
    """Records whose input columns carry the reference after the real inputs.

    Appending ``r`` to ``u`` makes every record or window projected with the inputs on its
    own basis, so the reference rows are the coefficients of ``r`` on exactly the blocks of
    the data.

    Parameters
    ----------
    records : sequence of Record
        The records.
    estimator : {"ls", "iv"}
        The estimator; ``"iv"`` needs ``reference``.
    reference : array_like, list of array_like, or None
        An ``(Ns,)`` / ``(Ns, m_r)`` array for one record, or a list with one array per
        record; checked whenever given.

    Returns
    -------
    records : list of Record
        The records, with the reference appended to the inputs for ``"iv"``.
    m_r : int
        Reference columns appended (0 for ``"ls"``).

    Raises
    ------
    ValueError
        If ``estimator`` is unknown, ``"iv"`` comes without a reference, the number of
        references differs from the number of records, their column counts differ, or a
        reference is invalid (:func:`check_reference`).
    """
    if not isinstance(estimator, str) or estimator not in ESTIMATORS:
        raise ValueError(f"estimator must be one of {ESTIMATORS}, got {estimator!r}")
    if reference is None:
        if estimator == "iv":
            raise ValueError(
                "estimator='iv' needs reference= (an external signal independent of the "
                "noise, e.g. the excitation added to the command in closed loop)"
            )
        return list(records), 0
    refs = reference if isinstance(reference, list | tuple) else [reference]
    if len(refs) != len(records):
        raise ValueError(
            f"reference: one array per record expected ({len(records)}), got {len(refs)}"
        )
    checked = [
        check_reference(r, rec.ns, f"reference[{i}]" if len(refs) > 1 else "reference")
        for i, (r, rec) in enumerate(zip(refs, records, strict=True))
    ]
    m_r = checked[0].shape[1]
    if any(c.shape[1] != m_r for c in checked):
        raise ValueError("reference: every record's reference needs the same number of columns")
    if estimator == "ls":
        return list(records), 0
    out = [
        Record(rec.t, np.hstack([rec.u, r]), rec.y, rec.t0, rec.resolution)
        for rec, r in zip(records, checked, strict=True)
    ]
    return out, m_r


def reference_instruments(R: Array, lag: BlockLag, n_regressors: int) -> Array:
    """The instrument rows ``[R; R M; ...; R M^L]`` (module docstring).

    Functions of the external signal alone are uncorrelated with the noise for every lag,
    and correlated with the regressors, whose noise-free parts are filtered ``r``.

    Parameters
    ----------
    R : ndarray, shape (m_r, N)
        The reference coefficients of all blocks.
    lag : BlockLag
        The blocks' lag.
    n_regressors : int
        The regressors to instrument, ``p_max (m + l)``; ``L`` gives at least
        ``ceil(INSTRUMENT_FACTOR * n_regressors)`` rows.

    Returns
    -------
    ndarray, shape (k, N)
        The instruments, rows scaled to unit RMS (all-zero rows dropped).

    References
    ----------
    .. [1] T. Soderstrom and P. Stoica, *Instrumental Variable Methods for System
       Identification*, Springer, 1983, ch. 3.

    Examples
    --------
    >>> from hdpbsid.core.blocks import BlockLag
    >>> from hdpbsid.core.varx import SampleShift
    >>> R = np.array([[1.0, 2.0, 3.0, 4.0]])
    >>> Psi = reference_instruments(R, BlockLag([SampleShift()], [4]), 1)
    >>> Psi.shape  # R and its lags 1..3, four instruments per regressor
    (4, 4)
    """
    m_r = R.shape[0]
    n_lags = int(np.ceil(INSTRUMENT_FACTOR * n_regressors / m_r))
    rows = [R]
    for j in range(1, n_lags):
        rows.append(lag.apply(R, j))
    Psi = np.vstack(rows)
    rms = np.sqrt(np.mean(Psi**2, axis=1))
    return Psi[rms > 0] / rms[rms > 0, None]
