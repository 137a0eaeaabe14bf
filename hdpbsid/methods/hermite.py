"""Method ``"hermite"``: HD-PBSID, PBSID in the Hermite-function domain (the thesis, §3.2).

The record ``t, u, y`` is projected onto ``N`` Hermite functions ``phi_n`` (the record
fills 90 % of their effective support, :func:`slbasis.basis`'s default time scale).  With
coefficient rows ``X, U, Y, E`` (columns = Hermite index) the state equation becomes
(eqs. (3)-(4) of the thesis; the windowed state picks up the boundary terms)

    X Dd = A X + B U + K E + x(t0) phi(t0)^T - x(tN) phi(tN)^T,      Y = C X + D U + E,

where ``Dd = -Dmat`` (= ``Dmat^T``, ``Dmat`` the tridiagonal d/dt matrix of
:meth:`slbasis.Basis.derivative_matrix`, column ``n`` = image of ``phi_n``) is the
projected derivative in row form.  The thesis's modified operator
``D' = (Dd/alpha + beta I)/gamma`` gives ``X D' = A' X + B' U + K' E + ...`` with
``A' = (A/alpha + beta I)/gamma``, ``B' = B/(alpha gamma)``, ``K' = K/(alpha gamma)``, and
the **integrator form** with ``M = D'^{-1}``:

    X = A' X M + B' U M + K' E M + (pseudo-inputs) M,

so the PBSID core runs with the lag ``W -> W M`` (regressors ``Z M^j``), ``M`` applied by
a tridiagonal (banded) solve.  Map back: ``A = alpha (gamma A' - beta I)``,
``B = alpha gamma B'``, ``K = alpha gamma K'``; ``C, D`` unchanged.

Truncation: the ``N x N`` cut of ``Dd`` misses, in its last column only, the coupling
``X_N Dd[N, N-1]`` to the discarded coefficient ``X_N`` (an unknown ``n``-vector).  It is
absorbed exactly as a pseudo-input with row ``e_{N-1}^T``, like the two boundary rows
``phi(t0)^T``, ``phi(tN)^T``; without these rows the initial and final states of a record
not at rest would bias the VARX regression.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hdpbsid.bases.basis_domain import (
    P_DEFAULT_RANGE,
    bandwidth,
    resolve_holds,
)
from hdpbsid.bases.family import Choice, Integrator, size_policy
from hdpbsid.bases.hermite_family import (
    HERMITE_BAND,
    HermiteFamily,
    default_hermite_N,
    hermite_lag,
)
from hdpbsid.bases.operator_scale import (
    MODE_ENERGY_FRACTION,
    OPERATOR_SCALE,
    AlphaEvidence,
)
from hdpbsid.bases.pipeline import Projection, make_blocks, project, solve
from hdpbsid.bases.segments import default_window, records_bandwidth
from hdpbsid.bases.settings import BasisSettings, resolve_settings
from hdpbsid.core.blocks import BlockLag
from hdpbsid.data.checks import check_order, check_positive_int
from hdpbsid.data.records import Dataset, Record, as_records
from hdpbsid.methods.hermite_iv import reference_instruments, with_reference
from hdpbsid.models.model import StateSpaceModel
from hdpbsid.runtime import library_call

__all__ = [
    "identify_hermite",
    "fit_hermite",
    "HermiteFamily",
    "hermite_lag",
    "default_hermite_N",
    "HERMITE_BAND",
]

Array = NDArray[np.float64]


#: the named rules ``alpha`` accepts besides a number (:func:`identify_hermite`)
ALPHA_RULES = ("basis", "dynamics")
#: the settings the candidates of an order/method sweep are fitted with
#: (:func:`hdpbsid.selection.auto.sweep_settings`): the operator scale of the basis rule, the
#: first pass of the default.  The scale from the identified modes costs one to two more
#: fits per order, each at an operator scale of its own, so no two orders share their
#: VARX stage and the sweep's cost grows with the orders tried; it is judged on the
#: held-out data for the chosen candidate only.
SWEEP_SETTINGS: dict[str, Any] = {"alpha": "basis"}


def _real(x: Any, name: str, positive: bool = True) -> float:
    if isinstance(x, bool) or not isinstance(x, int | float | np.integer | np.floating):
        raise TypeError(f"{name} must be a real number, got {type(x).__name__}")
    x = float(x)
    if not np.isfinite(x) or (positive and x <= 0):
        raise ValueError(f"{name} must be a finite number{' > 0' if positive else ''}, got {x}")
    return x


@library_call
def identify_hermite(
    t: Any,
    u: Any = None,
    y: Any = None,
    order: int | None = None,
    *,
    N: int | None = None,
    alpha: float | str | None = None,
    beta: float = 1.0,
    gamma: float = 1.0,
    scale: float | None = None,
    estimator: str = "ls",
    reference: Any = None,
    held_out: tuple | None = None,
    settings: BasisSettings | None = None,
    **shared: Any,
) -> StateSpaceModel:
    r"""HD-PBSID: a continuous-time model ``A, B, C, D, K`` from ``t, u, y`` in the
    Hermite-function domain.

    The record is projected on ``N`` Hermite functions; in their coefficients the
    derivative is a tridiagonal matrix (the ladder operators of the harmonic oscillator),
    so the state equation becomes an equation between coefficient rows, and its integrator
    form is the PBSID core's predictor with "one sample back" replaced by ``M = D'^{-1}``
    (module docstring).  The samples need not be uniform: the projection integrates the
    interpolants of the samples exactly.  Each record, or window of a long record, is a
    block projected on its own basis with its own boundary and truncation pseudo-inputs,
    all blocks stacked in one PBSID problem (:mod:`hdpbsid.bases.segments`), in which the
    pseudo-inputs are eliminated block by block.  Every choice made is reported, with its
    reason, in ``model.options``.

    Parameters
    ----------
    t : array_like, shape (Ns,), or list of records
        Increasing sample times (time units; need not be uniform); or a list of ``(t_i,
        u_i, y_i)`` records of the same system (then ``u = y = None``), each with its own
        time axis and initial state (:func:`hdpbsid.data.records.as_records`).
    u : array_like, shape (Ns, m), optional
        Inputs (None: a time series).
    y : array_like, shape (Ns, l)
        Outputs.
    order : int, optional
        Model order; None: the largest log-gap of the singular values among orders
        ``1..max_order``.
    N : int, optional
        Basis size of every block; None: per block, the basis covers twice the data
        bandwidth (:func:`~hdpbsid.bases.hermite_family.default_hermite_N`).  A given ``N``
        whose band ``3.6 N / T`` is below the data bandwidth is refused.
    alpha : float, {"basis", "dynamics"} or None, optional
        Operator scale (rad per time unit).  None: from the identified modes
        (:mod:`~hdpbsid.bases.operator_scale`) -- a first pass at ``4 * scale`` (the median
        over the blocks: ``A'`` is shared, so ``alpha`` must be), then the smallest
        ``alpha`` within 2 % of the minimal largest truncation factor ``(|alpha + lambda| /
        |alpha + i |lambda||)^p`` over the identified modes, re-identified until it settles;
        taken only when it simulates a single record better than the first pass's model by
        more than one standard error, first on the record itself, then on its last third
        held out from fits on the rest (several records keep ``4 * scale``).  A number is
        used as given, in one pass; ``"basis"``: ``4 * scale`` in one pass (HD-PBSID as
        published); ``"dynamics"``: from the modes, without the checks.  One decision,
        :meth:`OperatorScalePolicy.decide
        <hdpbsid.bases.operator_scale.OperatorScalePolicy.decide>`, whose typed way
        (:class:`~hdpbsid.bases.operator_scale.AlphaRule`) ``options["alpha_rule"]``
        states in words.
    beta : float, optional
        Shift of the integrator form, ``> 0``.
    gamma : float, optional
        Gain of the integrator form, ``> 0``.
    scale : float, optional
        Time scale of the functions; None: each block fills 90 % of their effective support
        (:func:`slbasis.basis`).
    estimator : {"ls", "iv"}, optional
        ``"ls"``: least squares, HD-PBSID as published (biased when the noise is correlated
        with the regressors, more so in closed loop); ``"iv"``: instrumental variables from
        ``reference``, consistent up to the VARX truncation
        (:mod:`hdpbsid.methods.hermite_iv`).
    reference : array_like, optional
        With ``estimator="iv"``: an external signal independent of the noise (e.g. the
        excitation added to the command), ``(Ns, k)``, one array per record.
    held_out : tuple, optional
        ``(t, u, y)`` of the same experiment kept out of this record (``method="auto"``
        passes its held-out part): the two models of ``alpha`` fitted on the whole record
        are compared on it instead (:meth:`OperatorScalePolicy.prove
        <hdpbsid.bases.operator_scale.OperatorScalePolicy.prove>`), and the rule taken is
        reported in ``options["refit_settings"]``.
    settings : BasisSettings, optional
        The settings every basis method shares (:class:`~hdpbsid.bases.settings.BasisSettings`).
    **shared
        The same settings as keywords, overriding ``settings``' fields: ``p``, ``f``
        (default: AIC over ``p`` in 2..4 with ``p (m + q + l) <= N / 6``, ``f = p``; an
        order needing ``f l >= n`` above that range gets ``p = ceil(n / l)``; an explicit
        ``p`` may go up to a determined VARX, :func:`~hdpbsid.bases.basis_domain.run_core`),
        ``max_order`` (10), ``boundary`` (True: rows ``phi(t0)``, ``phi(tN)`` as
        pseudo-inputs), ``regularize`` (``"gcv"``), ``feedthrough`` (False), ``stable_k``
        (False), ``normalize`` (True), ``input_hold`` (``"auto"``: project ``zoh`` and
        ``foh`` and keep the one whose order-free VARX fit has the smaller AIC,
        :func:`~hdpbsid.bases.basis_domain.hold_criterion`), ``window`` (``"auto"``: records
        longer than twice :func:`~hdpbsid.bases.segments.default_window` are cut into
        windows of bounded ``N``; None keeps them whole; a number is the length),
        ``n_jobs`` (joblib workers for the projection of windows).

    Returns
    -------
    StateSpaceModel
        The continuous-time innovation model; ``options`` lists every setting used and the
        reason for every choice (``N_rule``, ``alpha_rule``, ``p_rule``, ``input_hold_rule``,
        ...).

    Raises
    ------
    ValueError
        If an argument is out of range (the message names it), ``N`` does not cover the
        data bandwidth, or the record is too short for the order; raised before any long
        computation.
    TypeError
        If an argument has the wrong type or a keyword is not a shared setting.

    Notes
    -----
    With coefficient rows ``X, U, Y, E`` (columns = Hermite index) and the projected
    derivative ``Dd``,

    .. math::

        X D_d = A X + B U + K E + x(t_0)\phi(t_0)^\top - x(t_N)\phi(t_N)^\top, \qquad
        Y = C X + D U + E .

    With :math:`D' = (D_d/\alpha + \beta I)/\gamma` and :math:`M = D'^{-1}`,

    .. math::

        X = A' X M + B' U M + K' E M + (\text{pseudo-inputs})\,M, \qquad
        A' = \frac{A/\alpha + \beta I}{\gamma},\; B' = \frac{B}{\alpha\gamma},\;
        K' = \frac{K}{\alpha\gamma},

    and an eigenvalue :math:`\lambda` maps to :math:`(\lambda/\alpha + \beta)/\gamma`,
    inside the unit disc iff :math:`|\lambda + \alpha\beta| < \alpha\gamma`.

    References
    ----------
    .. [1] A. Chiuso, "The role of vector autoregressive modeling in predictor-based
       subspace identification", *Automatica* 43(6), 1034-1048, 2007.
    .. [2] J.-W. van Wingerden and M. Verhaegen, "Subspace identification of bilinear and
       LPV systems for open- and closed-loop data", *Automatica* 45(2), 372-381, 2009.
    .. [3] G. Szego, *Orthogonal Polynomials*, 4th ed., AMS, 1975, sec. 5.5 (Hermite
       functions).

    Examples
    --------
    The lightly damped second-order system (eigenvalues ``-0.4 +- 1.9596j``) under a sum
    of three sines, noise-free:

    >>> from hdpbsid.systems.linear import second_order, simulate_zoh
    >>> A, B, C, D = second_order()
    >>> t = np.arange(0.0, 40.0, 0.05)
    >>> u = (np.sin(0.7 * t) + np.sin(1.9 * t) + np.sin(3.1 * t))[:, None]
    >>> y = simulate_zoh(A, B, C, D, t, u)
    >>> model = identify_hermite(t, u, y, order=2)
    >>> np.sort_complex(model.eigenvalues).round(3)
    array([-0.4-1.961j, -0.4+1.961j])
    >>> model.options["N"]  # the band rule asks for fewer: clipped to N_MIN
    100
    """
    return fit_hermite(
        Dataset.of(t, u, y), order, N=N, alpha=alpha, beta=beta, gamma=gamma, scale=scale,
        estimator=estimator, reference=reference, held_out=held_out, settings=settings,
        **shared,
    )  # fmt: skip


@library_call
def fit_hermite(
    data: Dataset,
    order: int | None = None,
    *,
    N: int | None = None,
    alpha: float | str | None = None,
    beta: float = 1.0,
    gamma: float = 1.0,
    scale: float | None = None,
    estimator: str = "ls",
    reference: Any = None,
    held_out: tuple | None = None,
    settings: BasisSettings | None = None,
    **shared: Any,
) -> StateSpaceModel:
    """HD-PBSID on the records of ``data``: :func:`identify_hermite` in the registry's
    call shape (:func:`hdpbsid.methods.registry.get_fit`).

    Parameters
    ----------
    data : Dataset
        The records, checked (one record is a Dataset of one).
    order : int, optional
        Model order (:func:`identify_hermite`).
    N : int, optional
        Basis size (:func:`identify_hermite`).
    alpha : float, {"basis", "dynamics"} or None, optional
        Operator scale (:func:`identify_hermite`).
    beta : float, optional
        Shift of the integrator form.
    gamma : float, optional
        Gain of the integrator form.
    scale : float, optional
        Time scale of the functions.
    estimator : {"ls", "iv"}, optional
        The estimator of the VARX stage.
    reference : array_like, optional
        The instruments of ``estimator="iv"``.
    held_out : tuple, optional
        ``(t, u, y)`` kept out of the records, on which ``alpha`` is judged.
    settings : BasisSettings, optional
        The settings every basis method shares.
    **shared
        The same settings as keywords.

    Returns
    -------
    StateSpaceModel
        As :func:`identify_hermite` returns it.
    """
    c = _validate(data, order, N, alpha, beta, gamma, scale, estimator, reference, settings, shared)
    fit = _project(c)
    rec = c.records[0]
    evidence = AlphaEvidence(
        len(c.records), (rec.t, rec.u, rec.y), fit.band, _part_refit(c, fit), held_out
    )
    asked = c.alpha if c.alpha is not None else c.alpha_rule
    decision, model = OPERATOR_SCALE.decide(asked, fit.basis_alpha, fit, evidence)
    model.options.update(decision.options())
    model.report = model.report.but(alpha=Choice(decision.value, decision.text, decision.rule))
    if decision.refit_settings is not None:
        choice = Choice(decision.refit_settings, decision.text, decision.rule)
        model.report = model.report.but(refit_settings=choice)
    return model


identify_hermite.sweep_settings = SWEEP_SETTINGS  # type: ignore[attr-defined]
identify_hermite.fit = fit_hermite  # type: ignore[attr-defined]


@dataclass(frozen=True)
class _Call:
    """The validated arguments of :func:`identify_hermite`."""

    records: list[Record]
    proj_records: list[Record]
    m: int
    m_r: int
    st: BasisSettings
    order: int | None
    N: int | None
    scale: float | None
    beta: float
    gamma: float
    estimator: str
    alpha: float | None
    alpha_rule: str | None


def _validate(
    data: Dataset,
    order: Any,
    N: Any,
    alpha: Any,
    beta: Any,
    gamma: Any,
    scale: Any,
    estimator: Any,
    reference: Any,
    settings: Any,
    shared: dict[str, Any],
) -> _Call:
    """Check the arguments of :func:`identify_hermite` before any computation."""
    records = as_records(data)
    st = resolve_settings(settings, shared, "identify_hermite")
    order = check_order(order)
    # with a reference the records carry it as extra input columns (projected alike)
    proj_records, m_r = with_reference(records, estimator, reference)
    beta = _real(beta, "beta")
    gamma = _real(gamma, "gamma")
    N = None if N is None else check_positive_int(N, "N", 2)
    scale = None if scale is None else _real(scale, "scale")
    rule = alpha if isinstance(alpha, str) else None
    if rule is not None and rule not in ALPHA_RULES:
        raise ValueError(
            f"alpha must be a positive number, None or one of {ALPHA_RULES}, got {alpha!r}"
        )
    a = None if alpha is None or rule is not None else _real(alpha, "alpha")
    m = records[0].u.shape[1]
    return _Call(
        records, proj_records, m, m_r, st, order, N, scale, beta, gamma, estimator, a, rule
    )


class _Passes:
    """HD-PBSID of one projection at the operator scales asked for, each fitted once (the
    first pass's model is reused when the held-out check keeps its ``alpha``).

    With ``input_hold="auto"`` only the first fit compares both holds; the later passes
    (another ``alpha``) use the hold it chose.  The hold says how the input behaved
    between its samples, a property of the record that the operator scale does not
    change, and the first fit judges it on the same data and with the same criterion (the
    AIC of the VARX fit) as a later pass would: each later pass would only repeat the
    decision at the cost of two more VARX fits."""

    def __init__(
        self,
        c: _Call,
        proj: Projection,
        R: Array | None,
        options: dict,
        bases: tuple[HermiteFamily, list[Any]],
    ) -> None:
        self.c, self.proj, self.R, self.options = c, proj, R, options
        self.bases = bases
        #: the basis rule's operator scale, 4 * scale (the median over the blocks: ``A'``
        #: is shared, so ``alpha`` must be), the first pass of the modes' rule
        self.basis_alpha = 4.0 * options["scale"]
        self.fitted: dict[float, StateSpaceModel] = {}
        self.hold: Choice[str] | None = None
        self.criterion: dict[str, float] = {}

    def __call__(self, a: float) -> StateSpaceModel:
        if a not in self.fitted:
            self.fitted[a] = self._fit(a)
        return self.fitted[a]

    def instruments(self, lag: BlockLag) -> Array:
        """The reference instruments of the blocks' lag (:mod:`~hdpbsid.methods.hermite_iv`)."""
        st, R = self.c.st, self.R
        p_max = st.p if st.p is not None else P_DEFAULT_RANGE[1]
        return reference_instruments(R, lag, p_max * (self.c.m + self.proj.Y.shape[0]))

    def _fit(self, a: float) -> StateSpaceModel:
        c, opts = self.c, dict(self.options)
        holds = None
        if self.hold is not None:
            holds = (self.hold.value,)
            opts["input_hold_rule"] = self.hold.reason
            opts["input_hold_criterion"] = self.criterion
        op = Integrator(a, c.beta, c.gamma)
        ivs = self.instruments if self.R is not None else None
        fit = solve(self.proj, op, c.st, c.order, opts, holds=holds, instruments=ivs)
        if self.hold is None and len(self.proj.holds) > 1:
            self.criterion = fit.criterion
            self.hold = Choice(
                fit.hold,
                f"auto: zoh and foh judged at alpha = {a:.4g} (the first pass) by the "
                "AIC of the VARX fit, the smaller kept for every pass",
            )
        return fit.model

    @property
    def used_hold(self) -> str:
        """The input hold of the fits (the first pass's choice)."""
        return self.hold.value if self.hold is not None else self.proj.holds[0]

    def band(self) -> tuple[float, float]:
        """The band of modes that may set ``alpha``: from the lowest frequency below which
        :data:`~hdpbsid.bases.operator_scale.MODE_ENERGY_FRACTION` of a record's output
        energy lies to the narrowest basis band of the blocks."""
        family, bases = self.bases
        return (
            min(bandwidth(r.t, r.y, MODE_ENERGY_FRACTION) for r in self.c.records),
            min(family.band(b) for b in bases),
        )


def _project(c: _Call) -> _Passes:
    """The blocks of the validated call projected on their Hermite bases, ready to be fitted
    at any operator scale (its options: every choice made so far)."""
    family = HermiteFamily(c.scale)
    wb = records_bandwidth(c.records)
    q = family.q[c.st.boundary]
    blocks = make_blocks(
        c.proj_records,
        family,
        c.st.window,
        lambda: default_window(c.records, family.size_rate(wb), q, P_DEFAULT_RANGE[1]),
        size_policy(family, c.N, wb),
    )
    s_ref = float(np.median([b.scale for b in blocks.bases.values()]))
    proj = project(blocks, resolve_holds(c.st.input_hold, c.m), c.st.n_jobs)
    R = None
    if c.m_r:
        proj, R = proj.split_inputs(c.m)
    options = {
        "method": "hermite",
        **blocks.options(),
        "bandwidth": wb,
        "scale": s_ref,
        "centre": c.records[0].t0 + blocks.seg_bases[0].centre,
        "alpha_rule": "given",
        "boundary": c.st.boundary,
        "truncation": "last column of the cut D absorbed as a pseudo-input",
        "estimator": c.estimator,
    }
    return _Passes(c, proj, R, options, (family, list(blocks.bases.values())))


def _part_refit(c: _Call, fit: _Passes) -> Callable[..., StateSpaceModel]:
    """The fit of the held-out check (:meth:`OperatorScalePolicy.held_out_check
    <hdpbsid.bases.operator_scale.OperatorScalePolicy.held_out_check>`):
    ``refit(order, t, u, y, alpha)`` is HD-PBSID of a first part of the record with the
    call's settings at a given ``alpha``, in one pass, with the input hold the whole
    record's first pass chose (see :class:`_Passes`) and the reference cut alike."""
    ref = c.proj_records[0].u[:, c.m :] if c.m_r else None

    def refit(order: int, t_: Array, u_: Array, y_: Array, a: float) -> StateSpaceModel:
        part = _validate(
            Dataset.of(t_, u_, y_),
            order,
            c.N,
            a,
            c.beta,
            c.gamma,
            c.scale,
            c.estimator,
            None if ref is None else ref[: t_.shape[0]],
            c.st,
            {"input_hold": fit.used_hold},
        )
        return _project(part)(float(a))

    return refit
