"""``method="auto"``: choose the method and the order by their out-of-sample error.

Every candidate ``(method, order)`` is identified on the first part of the record
(``1 - holdout`` of the samples) and scored on the rest by the windowed simulation error
of :mod:`hdpbsid.criteria` (initial state fitted in each window, outputs weighted by
their variance), computed identically for every method.  The rule of
:func:`hdpbsid.criteria.choose_smallest_adequate` keeps, among all candidates ordered
by order (and, for equal orders, by the error), the first one whose error is not
within one standard error of the best candidate's; that ``(method, order)`` is then
identified on the whole record.  Held-out data judge the models, so a method that is
biased on this record, or an order the data do not support, loses by the measure a
user would apply to the result (simulation on data not used for estimation).

The comparison is reported in ``model.options["selection"]``: one row per candidate
with ``method``, ``order``, ``error`` (held-out residual energy relative to the output
variance), ``fit`` (percent), ``z`` (paired statistic against the best), ``time``
(seconds) and ``status`` (``"ok"`` or the error message).
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Sequence
from typing import Any

import numpy as np

from .checks import check_data, check_positive_int
from .criteria import (
    MIN_WINDOWS,
    SAMPLES_PER_STATE,
    SIGNIFICANCE_Z,
    WindowedError,
    choose_smallest_adequate,
    default_windows,
    is_uniform_grid,
    windowed_prediction_error,
    windowed_simulation_error,
)
from .model import StateSpaceModel

__all__ = ["identify_auto", "select_order", "select_model", "AUTO_METHODS", "HOLDOUT"]

#: methods tried by ``method="auto"`` (in this order; ``dt`` only on uniform samples)
AUTO_METHODS = ("hermite", "laguerre", "legendre", "dt")
#: share of the record held out for scoring (the last third, as users validate)
HOLDOUT = 1.0 / 3.0
#: largest order tried by default
AUTO_MAX_ORDER = 8
#: a method's orders are tried upwards until this many consecutive orders have not
#: lowered its best held-out error (two, so that one odd order that splits a pair of
#: modes badly does not end the sweep before the even order that completes it)
PATIENCE = 2


def _scores(model: StateSpaceModel, rec: tuple, windows: int) -> tuple[WindowedError, ...]:
    """``(simulation error, prediction error)`` of ``model`` on one record ``(t, u, y)``
    (the prediction error only on uniform samples)."""
    t, u, y = check_data(*rec)
    sim = windowed_simulation_error(model, t, u, y, windows)
    if not is_uniform_grid(t):
        return (sim,)
    return sim, windowed_prediction_error(model, t, u, y, windows)


def choose_predictor(model: StateSpaceModel, est: tuple, max_states: int) -> bool:
    """Whether ``model``'s one-step predictor uses its innovation gain ``K`` (module
    docstring): ``True`` when the prediction error with ``K`` is smaller than with
    ``K = 0`` (the simulation error) on the estimation data ``est`` (a ``(t, u, y)``
    record or ``([(t, u, y), ...], None, None)``).  Non-uniform samples: ``False``."""
    recs = est[0] if est[1] is None and isinstance(est[0], list) else [est]
    sim = pred = 0.0
    for rec in recs:
        t = np.asarray(rec[0])
        scores = _scores(model, rec, default_windows(t.size, max_states))
        if len(scores) < 2 or not scores[1].finite:
            return False
        sim += float(np.sum(scores[0].per_window))
        pred += float(np.sum(scores[1].per_window))
    return pred < sim


def _fit_one(
    get_method: Any, method: str, order: int, est: tuple, val: tuple, windows: int, options: dict
) -> dict[str, Any]:
    t0 = time.perf_counter()
    row: dict[str, Any] = {"method": method, "order": order}
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            model = get_method(method)(*est, order=order, **options.get(method, {}))
            if not isinstance(model, StateSpaceModel):
                raise TypeError(
                    f"method {method!r} returned {type(model).__name__}, expected StateSpaceModel"
                )
            use_k = choose_predictor(model, est, max(order, 1))
            scores = _scores(model, val, windows)
            err = scores[1] if use_k and len(scores) > 1 else scores[0]
        row.update(
            status="ok" if err.finite else "simulation overflow",
            criterion=err,
            predictor="innovation (K)" if use_k else "output error (K = 0)",
        )
    except (ValueError, np.linalg.LinAlgError) as exc:
        row.update(status=f"{type(exc).__name__}: {exc}", criterion=None, predictor=None)
    row["time"] = time.perf_counter() - t0
    return row


def _sweep(
    get_method: Any,
    method: str,
    orders: list[int],
    est: tuple,
    val: tuple,
    windows: int,
    options: dict,
) -> list[dict[str, Any]]:
    """The candidates of one method in increasing order, stopped once :data:`PATIENCE`
    consecutive orders have not lowered the method's best held-out error (module
    docstring); the orders left out get a row with ``status="skipped: ..."``."""
    rows: list[dict[str, Any]] = []
    best, stale = np.inf, 0
    for i, n in enumerate(orders):
        row = _fit_one(get_method, method, n, est, val, windows, options)
        rows.append(row)
        c = row["criterion"]
        err = c.total if c is not None and c.finite else np.inf
        if err < best:
            best, stale = err, 0
        elif np.isfinite(best):
            stale += 1
        if stale >= PATIENCE:
            reason = (
                f"skipped: orders {orders[i - PATIENCE + 1]}..{n} did not lower {method}'s "
                f"best held-out error"
            )
            for k in orders[i + 1 :]:
                rows.append(
                    {
                        "method": method,
                        "order": k,
                        "status": reason,
                        "criterion": None,
                        "predictor": None,
                        "time": 0.0,
                    }
                )
            break
    return rows


def _rows_table(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    table = []
    for r in rows:
        c = r["criterion"]
        table.append(
            {
                "method": r["method"],
                "order": r["order"],
                "error": c.total if c is not None else None,
                "fit": c.fit if c is not None else None,
                "z": r.get("z"),
                "predictor": r.get("predictor"),
                "time": r["time"],
                "status": r["status"],
            }
        )
    return table


def select_model(
    t: Any,
    u: Any,
    y: Any,
    methods: Sequence[str],
    orders: Sequence[int],
    *,
    holdout: float = HOLDOUT,
    n_jobs: int | None = None,
    method_options: dict[str, dict[str, Any]] | None = None,
) -> tuple[StateSpaceModel, list[dict[str, Any]], str]:
    """Score every ``(method, order)`` on held-out data and identify the chosen one on
    the whole record (module docstring).  Returns ``(model, table, rule)``.

    Raises ``ValueError`` when the record is too short to hold out enough scoring windows
    (the message says what would work) or when no candidate can be identified.
    """
    from .identify import get_method  # the registry lives in the front end
    from .records import as_records, is_record_list

    if not (isinstance(holdout, float | int) and 0.0 < float(holdout) < 1.0):
        raise ValueError(f"holdout must be a number in (0, 1), got {holdout!r}")
    several = is_record_list(t) and len(t) > 1
    if several:
        # several records: the last one is held out, the others identify the candidates
        recs = as_records(t, u, y)
        last = recs[-1]
        val = (last.t, last.u, last.y)
        est_list = [(r.t, r.u, r.y) for r in recs[:-1]]
        est: tuple = (est_list, None, None) if len(est_list) > 1 else est_list[0]
        n_val, where = last.t.size, "the last record"
    else:
        t, u, y = check_data(t, u, y)
        split = int(round(t.size * (1.0 - float(holdout))))
        est = (t[:split], u[:split], y[:split])
        val = (t[split:], u[split:], y[split:])
        n_val, where = t.size - split, f"the last {holdout:.0%} of the record"
    windows = default_windows(n_val, max(orders))
    if windows < MIN_WINDOWS:
        raise ValueError(
            f"choosing the order scores candidates on {where} ({n_val} samples) cut into "
            f"at least {MIN_WINDOWS} windows of {SAMPLES_PER_STATE * max(orders)} samples "
            f"({SAMPLES_PER_STATE} per state of the largest order {max(orders)}), i.e. "
            f"{MIN_WINDOWS * SAMPLES_PER_STATE * max(orders)} held-out samples; supply a "
            f"longer record, a smaller max_order, or give the order"
        )
    opts = method_options or {}
    orders = sorted(orders)
    if n_jobs is not None and n_jobs != 1:
        from joblib import Parallel, delayed

        sweeps = Parallel(n_jobs=n_jobs)(
            delayed(_sweep)(get_method, m, orders, est, val, windows, opts) for m in methods
        )
    else:
        sweeps = [_sweep(get_method, m, orders, est, val, windows, opts) for m in methods]
    rows = [r for sweep in sweeps for r in sweep]
    ok = [r for r in rows if r["criterion"] is not None and r["criterion"].finite]
    if not ok:
        detail = "; ".join(f"{r['method']} order {r['order']}: {r['status']}" for r in rows)
        raise ValueError(f"no candidate model could be identified and scored ({detail})")
    ok.sort(key=lambda r: (r["order"], r["criterion"].total))
    errors: list[WindowedError] = [r["criterion"] for r in ok]
    k, stats = choose_smallest_adequate(errors)
    for r, z in zip(ok, stats, strict=True):
        r["z"] = z
    # the chosen candidate identified on the whole record; if that fails (e.g. the
    # discrete model of the whole record has no continuous counterpart), the next
    # adequate candidate, then the remaining ones by held-out error
    adequate = [r for r, z in zip(ok, stats, strict=True) if z <= SIGNIFICANCE_Z]
    rest = sorted((r for r in ok if r not in adequate), key=lambda r: r["criterion"].total)
    failures = []
    for chosen in adequate[adequate.index(ok[k]) :] + rest:
        try:
            model = get_method(chosen["method"])(
                t, u, y, order=chosen["order"], **opts.get(chosen["method"], {})
            )
            break
        except (ValueError, np.linalg.LinAlgError) as exc:
            failures.append(f"{chosen['method']} order {chosen['order']}: {exc}")
    else:
        raise ValueError(
            "no scored candidate could be identified on the whole record: " + "; ".join(failures)
        )
    rule = (
        f"held-out windowed simulation error on {where} ({windows} windows); "
        f"smallest order within {SIGNIFICANCE_Z:g} standard error of the best held-out "
        f"error (one-standard-error rule)"
    )
    return model, _rows_table(rows), rule


def identify_auto(
    t: Any,
    u: Any,
    y: Any,
    order: int | None = None,
    *,
    methods: Sequence[str] | None = None,
    max_order: int | None = None,
    holdout: float = HOLDOUT,
    n_jobs: int | None = None,
    method_options: dict[str, dict[str, Any]] | None = None,
) -> StateSpaceModel:
    """``method="auto"``: every method of ``methods`` with orders ``1..max_order`` (or the
    given ``order``), the best by held-out simulation error (module docstring).

    ``methods``: default :data:`AUTO_METHODS` that are available (``dt`` is skipped for
    non-uniform ``t``); ``max_order``: default 8; ``holdout``: the scored share at the
    end of the record (``0 < holdout < 1``); ``n_jobs``: fit the candidates in parallel
    with joblib (results are identical to the serial run); ``method_options``: extra
    options per method, e.g. ``{"hermite": {"N": 400}}``.  ``model.options["selection"]``
    lists every candidate, ``options["order_selection"]`` the chosen method's.
    """
    from .identify import get_method, is_available
    from .methods.refine import is_uniform
    from .records import as_records

    recs = as_records(t, u, y)
    if len(recs) == 1:
        t, u, y = recs[0].t, recs[0].u, recs[0].y
    mo = AUTO_MAX_ORDER if max_order is None else check_positive_int(max_order, "max_order")
    orders = [check_positive_int(order, "order")] if order is not None else list(range(1, mo + 1))
    if methods is None:
        uniform = all(is_uniform(r.t) for r in recs)
        methods = [m for m in AUTO_METHODS if (uniform or m != "dt") and is_available(m)]
    else:
        methods = list(methods)
        for m in methods:
            get_method(m)  # raises for unknown names
    model, table, rule = select_model(
        t, u, y, methods, orders, holdout=holdout, n_jobs=n_jobs, method_options=method_options
    )
    chosen = model.options.get("method")
    model.options["selection"] = table
    model.options["order_selection"] = [r for r in table if r["method"] == chosen]
    model.options["selection_rule"] = rule
    return model


def select_order(
    method: str,
    t: Any,
    u: Any,
    y: Any,
    *,
    max_order: int | None = None,
    holdout: float = HOLDOUT,
    **options: Any,
) -> StateSpaceModel:
    """The order of ``method`` chosen by held-out simulation error (module docstring).

    Orders ``1..max_order`` (default 8) are identified on the first ``1 - holdout`` of
    the record and scored on the rest; the chosen order is identified on the whole
    record.  When the record is too short to score, the method chooses the order itself
    (from its singular values) and ``options["order_selection"]`` says so.
    """
    mo = AUTO_MAX_ORDER if max_order is None else check_positive_int(max_order, "max_order")
    from .identify import get_method

    try:
        model, table, rule = select_model(
            t,
            u,
            y,
            [method],
            list(range(1, mo + 1)),
            holdout=holdout,
            method_options={method: options},
        )
    except ValueError as exc:
        if "longer record" not in str(exc):
            raise
        model = get_method(method)(t, u, y, order=None, max_order=mo, **options)
        model.options["order_selection"] = f"singular values of the method ({exc})"
        return model
    model.options["order_selection"] = table
    model.options["order_selection_rule"] = rule
    return model
