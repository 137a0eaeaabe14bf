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
    alpha_from_dynamics,
    held_out_check,
    held_out_comparison,
    in_sample_screen,
)
from hdpbsid.bases.pipeline import Projection, make_blocks, project, solve
from hdpbsid.bases.segments import default_window, records_bandwidth
from hdpbsid.bases.settings import BasisSettings, resolve_settings
from hdpbsid.core.blocks import BlockLag
from hdpbsid.data.checks import check_data, check_order, check_positive_int
from hdpbsid.data.records import Record, as_records
from hdpbsid.methods.hermite_iv import reference_instruments, with_reference
from hdpbsid.models.model import StateSpaceModel
from hdpbsid.runtime import library_call

__all__ = [
    "identify_hermite",
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
    """HD-PBSID (the thesis, §3.2): continuous-time ``A, B, C, D, K`` from ``t, u, y``.

    ``t`` (Ns,) increasing, need not be uniform (projection weights from the spacing);
    ``u`` (Ns, m) or None, ``y`` (Ns, l).  Or ``t`` = a list of ``(t_i, u_i, y_i)``
    records of the same system (``u = y = None``), each with its own time axis and
    initial state (:func:`hdpbsid.data.records.as_records`).  See the module docstring for the
    equations.  Each record, or window of a long record, is a block: projected on its own
    basis with its own boundary and truncation pseudo-inputs, all blocks stacked in one
    PBSID problem (:mod:`hdpbsid.bases.segments`).

    The basis keywords are HD-PBSID's own (``N``, ``alpha``, ``beta``, ``gamma``,
    ``scale``); the settings every basis method shares (``p``, ``f``, ``max_order``,
    ``boundary``, ``regularize``, ``feedthrough``, ``stable_k``, ``normalize``,
    ``input_hold``, ``window``, ``n_jobs``) come as keywords (``**shared``) or as
    ``settings=`` :class:`~hdpbsid.bases.settings.BasisSettings`, keywords overriding
    its fields; they are validated once, there.

    Defaults (all reported in ``model.options``):

    * ``window="auto"``: records longer than twice the default window
      (:func:`~hdpbsid.bases.segments.default_window`) are cut into windows of bounded
      ``N``; None keeps every record whole; a number is the window length in seconds;
      ``n_jobs`` projects windows that do not share a time axis in parallel (joblib);
    * ``N``: per block, the basis covers twice the data bandwidth
      (:func:`default_hermite_N`); an explicit ``N`` (used for every block) whose band
      ``3.6 N / T`` is below the data bandwidth raises ``ValueError``;
    * ``scale``: each block fills 90 % of the effective support (``slbasis.basis``);
    * ``alpha``: from the identified modes (:mod:`~hdpbsid.bases.operator_scale`): a
      first pass at ``4 * scale`` (the median over the blocks: ``A'`` is shared, so
      ``alpha`` must be), then the smallest ``alpha`` that minimises, within 2 %, the
      largest truncation factor ``(|alpha + lambda| / |alpha + i |lambda||)^p`` over the
      identified modes (unstable ones by their mirror images), re-identified until it
      settles; taken only when it simulates a single record better than the first
      pass's model by more than one standard error, first on the record itself
      (:func:`~hdpbsid.bases.operator_scale.in_sample_screen`), then on its last third
      held out from fits on the rest (the burden of proof on the change:
      :func:`~hdpbsid.bases.operator_scale.held_out_check`); several records keep
      ``4 * scale``.  ``4 * scale`` alone follows ``sqrt(N) / T``, not the dynamics
      (stiff system ``-50, -0.5 +- 2i`` at 40 dB: slow pair 17 % off).
      ``options["alpha_rule"]``, ``["alpha_passes"]``, ``["alpha_check"]`` say what was
      done.  An explicit number is used as given, in one pass; ``alpha="basis"``:
      ``4 * scale`` in one pass (HD-PBSID as published); ``alpha="dynamics"``: from the
      modes, without the checks.  ``beta = gamma = 1``: an eigenvalue ``lambda`` maps to
      ``(lambda/alpha + beta)/gamma``, inside the unit disc iff
      ``|lambda + alpha beta| < alpha gamma``;
    * ``held_out = (t, u, y)``: data of the same experiment kept out of this record
      (``method="auto"`` passes its held-out part): the two models of ``alpha`` fitted on
      the whole record are compared on it instead, by the same rule
      (:func:`~hdpbsid.bases.operator_scale.held_out_comparison`), so the operator
      scale is judged by the same data as the order and the method, on all of them
      rather than on a third of a second split, and without refits; the model then
      carries the rule taken (``"basis"`` or ``"dynamics"``) in
      ``options["refit_settings"]``, which ``method="auto"`` passes to the refit on the
      whole record, as it passes the order;
    * ``p``: AIC over 2..4 with ``p (m + q + l) <= N / 6``; ``f = p`` (closed-loop
      quadrotor at 20 dB: with 2..6 AIC picked 6, and p = 4 has about half the spread);
      an order needing ``f l >= n`` above that range gets ``p = ceil(n / l)`` within
      ``N / 6``; an explicit ``p`` may go up to the real limit, a determined VARX
      (``p (m + q + l) < N - p``; :func:`~hdpbsid.bases.basis_domain.run_core`);
    * ``order``: largest log-gap of the singular values (orders ``1..max_order``, 10);
    * ``input_hold="auto"``: how the input behaves between samples (``"zoh"`` held,
      ``"foh"`` linear, ``"trapezoid"`` the old product quadrature); ``"auto"`` projects both
      ``zoh`` and ``foh`` (:func:`~hdpbsid.bases.basis_domain.project_record`) and keeps
      the one whose order-free VARX fit has the smaller AIC
      (:func:`~hdpbsid.bases.basis_domain.hold_criterion`: one decision for every
      order), in the first operator-scale pass; the later passes and the held-out fits
      keep its choice;
    * ``boundary=True``: boundary rows ``phi(t0)``, ``phi(tN)`` as pseudo-inputs;
    * ``regularize="gcv"``, ``feedthrough=False``, ``stable_k=False``, ``normalize=True``
      as in :func:`hdpbsid.methods.dt.identify_dt`;
    * ``estimator="ls"``: least squares, HD-PBSID as published (biased when the noise is
      correlated with the regressors, more so in closed loop); ``"iv"``: instrumental
      variables from ``reference`` (an external signal independent of the noise, e.g.
      the excitation added to the command; one array per record), consistent up to the
      VARX truncation (:mod:`hdpbsid.methods.hermite_iv`).
    """
    c = _validate(
        t, u, y, order, N, alpha, beta, gamma, scale, estimator, reference, settings, shared
    )
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
    alpha0 = 4.0 * s_ref if c.alpha is None else c.alpha
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
    fit = _Passes(c, proj, R, options)
    if c.alpha is not None:
        return fit(alpha0)
    if c.alpha_rule == "basis" or len(c.records) > 1:
        return _basis_rule(fit(alpha0), c.alpha_rule)
    band = (
        min(bandwidth(r.t, r.y, MODE_ENERGY_FRACTION) for r in c.records),
        min(family.band(b) for b in blocks.bases.values()),
    )
    return _dynamics_rule(fit, c, alpha0, band, held_out)


identify_hermite.sweep_settings = SWEEP_SETTINGS  # type: ignore[attr-defined]


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
    t: Any,
    u: Any,
    y: Any,
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
    records = as_records(t, u, y)
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

    def __init__(self, c: _Call, proj: Projection, R: Array | None, options: dict) -> None:
        self.c, self.proj, self.R, self.options = c, proj, R, options
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


def _basis_rule(model: StateSpaceModel, rule: str | None) -> StateSpaceModel:
    """The model at ``alpha = 4 * scale``, asked for or the only checkable one."""
    model.options["alpha_rule"] = "4 * scale (median over blocks); " + (
        "asked for (alpha='basis')"
        if rule == "basis"
        else "several records: no held-out check of a change"
    )
    return model


def _dynamics_rule(
    fit: _Passes, c: _Call, alpha0: float, band: tuple[float, float], held_out: Any
) -> StateSpaceModel:
    """``alpha`` from the identified modes
    (:func:`~hdpbsid.bases.operator_scale.alpha_from_dynamics`), kept only when it proves
    itself (:func:`_check_change`) unless asked for (``alpha="dynamics"``)."""
    a_new, model, info = alpha_from_dynamics(fit, alpha0, band)
    info["alpha_rule"] += " (4 * scale, median over blocks)"
    alpha = a_new
    if c.alpha_rule == "dynamics":
        info["alpha_rule"] += "; taken without a held-out check (alpha='dynamics')"
    elif a_new != alpha0:
        keep, how, where = _check_change(fit, c, model, alpha0, a_new, held_out)
        info["alpha_check"] = how
        if not keep:
            model, alpha = fit(alpha0), alpha0
            info["alpha_rule"] += (
                f"; not better on the {where} by more than one SE: the first pass's alpha kept"
            )
    model.options.update(info)
    if held_out is not None:
        # the rule the held-out data chose, for the refit on a longer record (whose basis
        # rule gives another 4 * scale and whose modes ask for their own alpha)
        settings = {"alpha": "basis" if alpha == alpha0 else "dynamics"}
        model.options["refit_settings"] = settings
        model.report = model.report.but(refit_settings=Choice(settings, info["alpha_rule"]))
    return model


def _check_change(
    fit: _Passes,
    c: _Call,
    model: StateSpaceModel,
    alpha0: float,
    a_new: float,
    held_out: Any,
) -> tuple[bool, str, str]:
    """Whether ``a_new`` beats ``alpha0`` by more than one standard error: on the caller's
    held-out data (:func:`~hdpbsid.bases.operator_scale.held_out_comparison`), else on the
    record itself (:func:`~hdpbsid.bases.operator_scale.in_sample_screen`, the necessary
    condition, no refits) and then on its last third held out from refits on the rest
    (:func:`~hdpbsid.bases.operator_scale.held_out_check`).  Returns
    ``(keep, how, which data)``."""
    if held_out is not None:
        keep, how = held_out_comparison(
            fit(alpha0), model, check_data(*held_out), model.n, (alpha0, a_new)
        )
        return keep, how, "held-out data"
    rec = c.records[0]
    keep, how = in_sample_screen(fit(alpha0), model, (rec.t, rec.u, rec.y), (alpha0, a_new))
    if keep:
        ref = c.proj_records[0].u[:, c.m :] if c.m_r else None
        hold = fit.used_hold

        def refit(t_: Array, u_: Array, y_: Array, a: float) -> StateSpaceModel:
            return identify_hermite(
                t_,
                u_,
                y_,
                order=model.n,
                alpha=a,
                N=c.N,
                beta=c.beta,
                gamma=c.gamma,
                scale=c.scale,
                estimator=c.estimator,
                reference=None if ref is None else ref[: t_.shape[0]],
                settings=c.st,
                # the hold the whole record's first pass chose (see _Passes)
                input_hold=hold,
            )

        keep, how = held_out_check(refit, rec.t, rec.u, rec.y, a_new, alpha0, model.n)
    return keep, how, "held-out part"
