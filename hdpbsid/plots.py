"""Figures for identified models (matplotlib, Agg; no windows are ever opened).

The CLI writes a figure with what decided the order (the held-out error per order beside
the singular values), the Bode magnitude and phase and the measured vs simulated outputs
with their fit; ``hdpbsid validate`` one with the
residual tests (:func:`plot_validation`).  Figures are built on
:class:`matplotlib.figure.Figure` with an Agg canvas, never through ``pyplot``, so the
library neither changes the global backend nor keeps figures alive.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hdpbsid.data.checks import check_data
from hdpbsid.models.assessment import fit_percent
from hdpbsid.models.criteria import SIGNIFICANCE_Z
from hdpbsid.models.model import StateSpaceModel, fit_statistics

__all__ = [
    "new_figure",
    "plot_identification",
    "order_criterion",
    "plot_order_criterion",
    "plot_eigenvalues",
    "save_figure",
    "display_fit",
    "DisplayFit",
    "plot_singular_values",
    "plot_bode",
    "plot_eigenvalue_scatter",
    "plot_outputs",
    "plot_validation",
]


@dataclass
class DisplayFit:
    """Simulated output for display, and how it was obtained (:func:`display_fit`).

    Parameters
    ----------
    y_sim : ndarray, shape (Ns, l)
        The simulated output.
    fit : ndarray, shape (l,)
        Percent per output, the NRMSE fit of MATLAB's ``compare``
        (:func:`hdpbsid.models.assessment.fit_percent`).
    vaf : ndarray, shape (l,)
        Percent per output, the variance accounted for.
    kind : str
        How ``y_sim`` was obtained (whole record, or segments and their length).
    """

    y_sim: NDArray[np.float64]
    fit: NDArray[np.float64]
    vaf: NDArray[np.float64]
    kind: str

    def __repr__(self) -> str:
        return f"DisplayFit(fit={np.array2string(self.fit, precision=2)} %, {self.kind})"


def display_fit(
    model: StateSpaceModel, t: Any, u: Any, y: Any, growth: float = 100.0
) -> DisplayFit:
    r"""Measured-vs-simulated fit that stays meaningful for open-loop *unstable* models.

    Parameters
    ----------
    model : StateSpaceModel
        The model.
    t : array_like, shape (Ns,)
        Sample times.
    u : array_like, shape (Ns, m)
        Input.
    y : array_like, shape (Ns, l)
        Measured output.
    growth : float, optional
        The largest factor by which the fastest unstable mode may grow over one segment.

    Returns
    -------
    DisplayFit
        The simulated output, its fit and VAF, and how it was obtained.

    Notes
    -----
    A stable model is simulated over the whole record (:meth:`StateSpaceModel.fit`, initial
    state by least squares).  A free-run simulation of an unstable model diverges even for
    the true model (a pole at :math:`+3` grows by :math:`e^{90} \approx 10^{39}` over 30 s),
    so the record is cut into segments over which the fastest unstable mode grows by at
    most ``growth``, :math:`T_{\mathrm{seg}} = \ln(\mathrm{growth}) / \max
    \operatorname{Re}\lambda`, and each segment is simulated from its own least-squares
    initial state.
    """
    t, u, y = check_data(t, u, y)
    max_re = float(np.max(model.eigenvalues.real)) if model.n else -1.0
    if max_re <= 0:
        res = model.fit(t, u, y)
        return DisplayFit(res.y_sim, res.fit, res.vaf, "simulation, x0 estimated")
    t_seg = np.log(growth) / max_re
    edges = np.searchsorted(t, np.arange(t[0], t[-1], t_seg))
    edges = np.unique(np.append(edges, t.size))
    y_sim = np.empty_like(y)
    for a, b in zip(edges[:-1], edges[1:], strict=True):
        b = max(b, min(a + 2, t.size))
        if b - a < 2:
            y_sim[a:b] = y[a:b]
            continue
        y_sim[a:b] = model.fit(t[a:b], u[a:b], y[a:b]).y_sim
    vaf, _ = fit_statistics(y, y_sim)
    return DisplayFit(
        y_sim,
        fit_percent(y, y_sim),
        vaf,
        f"simulation on segments of {t_seg:.3g} {model.time_unit}, x0 estimated per segment",
    )


def _names(
    model: StateSpaceModel,
    output_names: list[str] | None,
    input_names: list[str] | None,
    l: int,
    m: int,
) -> tuple[list[str], list[str]]:
    """The output and input names for a figure: those given, else the model's (when they
    fit the record's channel counts), else ``y1, ...`` and ``u1, ...``."""
    onames = output_names or getattr(model, "output_names", None) or []
    inames = input_names or getattr(model, "input_names", None) or []
    if len(onames) != l:
        onames = [f"y{i + 1}" for i in range(l)]
    if len(inames) != m:
        inames = [f"u{j + 1}" for j in range(m)]
    return list(onames), list(inames)


def new_figure(figsize: tuple[float, float] = (10.0, 8.0)) -> Any:
    """A :class:`matplotlib.figure.Figure` attached to an Agg canvas.

    Built without ``pyplot``, so the library neither changes the global backend nor keeps
    figures alive.

    Parameters
    ----------
    figsize : tuple of two float, optional
        Width and height in inches.

    Returns
    -------
    matplotlib.figure.Figure
        The empty figure.

    Raises
    ------
    ImportError
        If matplotlib is not installed (extra ``plots``).
    """
    try:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
    except ImportError as exc:  # pragma: no cover - matplotlib is in the plots extra
        raise ImportError("plots need matplotlib: pip install 'slbasis-hdpbsid[plots]'") from exc
    fig = Figure(figsize=figsize, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def save_figure(fig: Any, path: str | Path, dpi: int = 110) -> Path:
    """Write a figure as an image.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure.
    path : str or path-like
        The file; the format follows the suffix (PNG when there is none); missing parent
        directories are created.
    dpi : int, optional
        Resolution of raster formats.

    Returns
    -------
    pathlib.Path
        The path written (with ``.png`` added when it had no suffix).
    """
    path = Path(path)
    if not path.suffix:
        path = path.with_suffix(".png")
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=dpi)
    return path


def _default_frequencies(model: StateSpaceModel, t: NDArray[np.float64]) -> NDArray[np.float64]:
    """Log grid from the record (``2 pi / T``) to Nyquist of the mean step, widened to
    cover every eigenvalue magnitude by a decade."""
    T = float(t[-1] - t[0])
    lo = 2 * np.pi / T
    hi = np.pi / float(np.mean(np.diff(t)))
    mags = np.abs(model.eigenvalues)
    mags = mags[mags > 0]
    if mags.size:
        lo = min(lo, mags.min() / 10)
        hi = max(hi, mags.max() * 10)
    return np.logspace(np.log10(lo), np.log10(hi), 400)


def _order_table(model: Any) -> list[dict[str, Any]] | None:
    """The chosen method's candidates of the held-out selection as rows
    (``model.report``), or ``None`` when the order was not chosen on held-out data."""
    rows = model.report.order_candidates()
    return [c.as_dict() for c in rows] if rows else None


def order_criterion(
    table: Any,
) -> tuple[NDArray[np.int64], NDArray[np.float64], float | None] | None:
    """The held-out criterion per order from the candidates of a model's selection.

    Parameters
    ----------
    table : list of dict or object
        The selection table (:func:`hdpbsid.selection.auto.select_model`): one row per
        candidate with its held-out error ``error`` (0 = perfect, 1 = no better than the
        mean), its ``order`` and ``z``, its excess over the best candidate's error in
        standard errors (:func:`hdpbsid.models.criteria.choose_smallest_adequate`).

    Returns
    -------
    tuple (orders, errors, se) or None
        Per order the best candidate's error, and the standard error
        ``(error - best) / z`` (``None`` when no row has a finite, nonzero ``z``); ``None``
        when the table is not a list of rows (the order was given, or chosen by the
        singular values).

    Notes
    -----
    Every row with a finite, nonzero ``z`` gives the same standard error (both are the same
    sums divided by the same held-out output energy); their median is returned.
    """
    if not isinstance(table, list):
        return None
    rows = [
        r
        for r in table
        if isinstance(r, dict) and r.get("error") is not None and np.isfinite(r["error"])
    ]
    if not rows:
        return None
    best: dict[int, float] = {}
    for r in rows:
        o = int(r["order"])
        best[o] = min(best.get(o, np.inf), float(r["error"]))
    orders = np.array(sorted(best), dtype=np.int64)
    errors = np.array([best[o] for o in orders])
    e_min = float(errors.min())
    ses = [
        (float(r["error"]) - e_min) / float(r["z"])
        for r in rows
        if r.get("z") is not None and np.isfinite(r["z"]) and float(r["z"]) > 0
    ]
    return orders, errors, (float(np.median(ses)) if ses else None)


def plot_order_criterion(model: StateSpaceModel, ax: Any) -> bool:
    """Draw what chose the order (:func:`order_criterion`).

    Per order, the best candidate's held-out error above the best of all, in standard errors
    of that error (bars: one standard error), the line of the one-standard-error rule (the
    smallest order below it is chosen) and the model's order marked.  The vertical axis is
    linear up to 1 and logarithmic beyond, so an order far off and the close calls both
    show.  Without a standard error the errors themselves are drawn (log scale).

    Parameters
    ----------
    model : StateSpaceModel
        The model, with its selection's candidates in ``model.report``.
    ax : matplotlib.axes.Axes
        Where to draw.

    Returns
    -------
    bool
        ``False`` (a note drawn instead) when the model carries no selection table.
    """
    crit = order_criterion(_order_table(model))
    if crit is None:
        ax.text(
            0.5,
            0.5,
            "order given, or chosen\nwithout a held-out score",
            ha="center",
            va="center",
            transform=ax.transAxes,
        )
        ax.set_axis_off()
        return False
    orders, errors, se = crit
    if se is not None and se > 0:
        values = (errors - errors.min()) / se
        ax.errorbar(orders, values, yerr=1.0, fmt="o-", ms=4, capsize=3, label="held-out error")
        ax.axhline(SIGNIFICANCE_Z, color="0.4", ls=":", lw=1, label="best + 1 SE")
        ax.set_yscale("symlog", linthresh=1.0)
        ax.set_ylabel("held-out error - best [SE]")
    else:
        values = errors
        ax.plot(orders, values, "o-", ms=4, label="held-out error")
        ax.set_yscale("log")
        ax.set_ylabel("held-out error (1 = mean)")
    if model.n in set(orders.tolist()):
        k = int(np.flatnonzero(orders == model.n)[0])
        ax.plot(model.n, values[k], "o", ms=10, mfc="none", mec="C3", mew=2, label="chosen")
    ax.set_xticks(orders)
    ax.set_xlabel("order")
    ax.set_title("Order: held-out prediction error")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(loc="upper right", fontsize="small")
    return True


def plot_identification(
    model: StateSpaceModel,
    t: Any,
    u: Any,
    y: Any,
    output_names: list[str] | None = None,
    input_names: list[str] | None = None,
    w: Any | None = None,
    true_model: StateSpaceModel | None = None,
    title: str | None = None,
) -> Any:
    """Summary figure: what decided the order, the frequency response, the fit.

    * the held-out criterion per order (:func:`plot_order_criterion`) beside the singular
      values of the PBSID SVD step (log scale, the order marked);
    * Bode magnitude (dB) and phase (degrees) of every input-output pair, dashed for
      ``true_model`` if given;
    * each output measured vs simulated (:func:`display_fit`: whole record for a stable
      model, short segments for an unstable one), the fit (NRMSE, percent) in the legend.

    Parameters
    ----------
    model : StateSpaceModel
        The identified model.
    t : array_like, shape (Ns,)
        Sample times.
    u : array_like, shape (Ns, m)
        Input.
    y : array_like, shape (Ns, l)
        Measured output.
    output_names, input_names : list of str, optional
        Channel names (default the model's ``output_names`` / ``input_names``).
    w : array_like, optional
        Angular frequencies of the Bode plot in rad per the model's ``time_unit``; default
        from the record length to the Nyquist frequency, widened to every eigenvalue.
    true_model : StateSpaceModel, optional
        Drawn dashed for comparison.
    title : str, optional
        The figure's title.

    Returns
    -------
    matplotlib.figure.Figure
        Save it with :func:`save_figure`.

    Raises
    ------
    ValueError
        If the record fails :func:`hdpbsid.data.checks.check_data`.
    """
    t, u, y = check_data(t, u, y)
    l = y.shape[1]
    m = u.shape[1]
    onames, inames = _names(model, output_names, input_names, l, m)
    fig = new_figure((11.0, 6.4 + 2.2 * l))
    gs = fig.add_gridspec(l + 2, 2, height_ratios=[1.3, 1.3] + [1.0] * l)
    plot_order_criterion(model, fig.add_subplot(gs[0, 0]))
    _singular_value_panel(model, fig.add_subplot(gs[0, 1]))
    ax_mag = fig.add_subplot(gs[1, 0])
    ax_ph = fig.add_subplot(gs[1, 1], sharex=ax_mag)
    wgrid = None
    if m:
        wgrid = _default_frequencies(model, t) if w is None else np.asarray(w, dtype=float)
    _bode_panels((ax_mag, ax_ph), model, true_model, wgrid, (onames, inames))
    fit = display_fit(model, t, u, y)
    for i in range(l):
        ax = fig.add_subplot(gs[i + 2, :])
        ax.plot(t, y[:, i], color="0.6", lw=0.8, label="measured")
        ax.plot(t, fit.y_sim[:, i], color="C0", lw=1.0, label=f"simulated, fit {fit.fit[i]:.1f} %")
        ax.set_ylabel(onames[i])
        ax.legend(loc="upper right", fontsize="small")
        ax.grid(True, alpha=0.3)
        if i == l - 1:
            ax.set_xlabel(f"time [{model.time_unit}] ({fit.kind})")
    method = model.report.method or "?"
    fig.suptitle(title or f"hdpbsid: method {method!r}, order {model.n}")
    return fig


def _singular_value_panel(model: StateSpaceModel, ax: Any) -> None:
    """The singular values of the subspace step (log scale), the model's order marked."""
    sv = model.singular_values
    if sv is not None and np.size(sv):
        sv = np.asarray(sv, dtype=float)
        idx = np.arange(1, sv.size + 1)
        ax.semilogy(idx, sv, "o-", ms=3)
        ax.axvline(model.n + 0.5, color="C3", ls="--", label=f"order {model.n}")
        ax.legend(loc="upper right", fontsize="small")
        ax.grid(True, which="both", alpha=0.3)
    else:
        ax.text(0.5, 0.5, "no singular values recorded", ha="center", transform=ax.transAxes)
    ax.set_xlabel("index")
    ax.set_ylabel("singular value")
    ax.set_title("Singular values of the subspace step")


def _bode_panels(
    axes: tuple[Any, Any],
    model: StateSpaceModel,
    true_model: StateSpaceModel | None,
    wgrid: NDArray[np.float64] | None,
    names: tuple[list[str], list[str]],
) -> None:
    """Bode magnitude and phase of every input-output pair on ``wgrid`` (``None``: the
    model has no inputs), dashed for ``true_model``."""
    ax_mag, ax_ph = axes
    onames, inames = names
    if wgrid is not None:
        G = model.frequency_response(wgrid)
        Gt = true_model.frequency_response(wgrid) if true_model is not None else None
        pairs = [(i, j) for i in range(len(onames)) for j in range(len(inames))]
        for k, (i, j) in enumerate(pairs):
            color = f"C{k % 10}"
            _bode_pair(ax_mag, ax_ph, wgrid, G[i, j], color, f"{inames[j]} -> {onames[i]}")
            if Gt is not None:
                _bode_pair(ax_mag, ax_ph, wgrid, Gt[i, j], color, None, ls="--", lw=1)
        ax_mag.legend(fontsize="small")
    else:
        ax_mag.text(0.5, 0.5, "no inputs", ha="center", transform=ax_mag.transAxes)
    dashed = " (dashed: true)" if true_model is not None else ""
    for ax, ylabel, name in ((ax_mag, "|G| [dB]", "magnitude"), (ax_ph, "phase [deg]", "phase")):
        ax.set_xlabel(f"frequency [rad/{model.time_unit}]")
        ax.set_ylabel(ylabel)
        ax.set_title(f"Bode {name}{dashed}")
        ax.grid(True, which="both", alpha=0.3)


def _bode_pair(
    ax_mag: Any, ax_ph: Any, w: Any, g: Any, color: str, label: str | None, **style: Any
) -> None:
    """Magnitude (dB) and unwrapped phase (degrees) of one frequency response."""
    ax_mag.semilogx(
        w, 20 * np.log10(np.maximum(np.abs(g), 1e-300)), color=color, label=label, **style
    )
    ax_ph.semilogx(w, np.degrees(np.unwrap(np.angle(g))), color=color, **style)


def plot_eigenvalues(
    identified: Any, true: Any | None = None, title: str = "Eigenvalues", time_unit: str = "s"
) -> Any:
    """Identified (crosses) and true (circles) eigenvalues in the complex plane.

    Parameters
    ----------
    identified : array_like of complex
        The identified eigenvalues.
    true : array_like of complex, optional
        The true ones.
    title : str, optional
        The axes' title.
    time_unit : str, optional
        The axes are in rad per this unit.

    Returns
    -------
    matplotlib.figure.Figure
        The figure.
    """
    fig = new_figure((5.5, 4.5))
    ax = fig.add_subplot(1, 1, 1)
    ev = np.asarray(identified, dtype=complex).ravel()
    if true is not None:
        tv = np.asarray(true, dtype=complex).ravel()
        ax.plot(tv.real, tv.imag, "o", mfc="none", ms=10, label="true")
    ax.plot(ev.real, ev.imag, "x", ms=8, mew=2, label="identified")
    ax.axvline(0.0, color="0.5", lw=0.8)
    ax.axhline(0.0, color="0.5", lw=0.8)
    ax.set_xlabel(f"Re [rad/{time_unit}]")
    ax.set_ylabel(f"Im [rad/{time_unit}]")
    ax.set_title(title)
    ax.legend()
    return fig


# -- study figures (hdpbsid.studies) ------------------------------------------------------
def plot_singular_values(
    singular_values: Any, order: int | None = None, ax: Any | None = None, title: str = ""
) -> Any:
    """Singular values of the PBSID SVD step on a log scale, ``order`` marked.

    Parameters
    ----------
    singular_values : array_like
        The singular values.
    order : int, optional
        The chosen order, marked.
    ax : matplotlib.axes.Axes, optional
        Where to draw; a new figure when ``None``.
    title : str, optional
        The axes' title.

    Returns
    -------
    matplotlib.axes.Axes or matplotlib.figure.Figure
        ``ax`` when given, else the new figure.
    """
    fig = None
    if ax is None:
        fig = new_figure((5.5, 4.0))
        ax = fig.add_subplot(1, 1, 1)
    sv = np.asarray(singular_values, dtype=float).ravel()
    idx = np.arange(1, sv.size + 1)
    ax.semilogy(idx, sv, "o-", ms=4)
    if order is not None:
        ax.axvline(order + 0.5, color="C3", ls="--", label=f"order {order}")
        ax.legend(loc="upper right")
    ax.set_xlabel("index")
    ax.set_ylabel("singular value")
    ax.set_title(title or "Singular values (order selection)")
    ax.grid(True, which="both", alpha=0.3)
    return fig if fig is not None else ax


def plot_bode(
    models: dict[str, StateSpaceModel],
    w: Any,
    true_model: StateSpaceModel | None = None,
    input_names: list[str] | None = None,
    output_names: list[str] | None = None,
    title: str = "Bode diagram",
) -> Any:
    """Magnitude and phase of every input-output pair of several models.

    The models are drawn solid, ``true_model`` dashed; one column per output.

    Parameters
    ----------
    models : dict of str to StateSpaceModel
        Label -> model.
    w : array_like
        Angular frequencies (rad per the models' time unit).
    true_model : StateSpaceModel, optional
        Drawn dashed.
    input_names, output_names : list of str, optional
        Channel names (default the first model's).
    title : str, optional
        The figure's title.

    Returns
    -------
    matplotlib.figure.Figure
        The figure.

    Raises
    ------
    ValueError
        If ``models`` is empty.
    """
    w = np.asarray(w, dtype=float).ravel()
    first = next(iter(models.values())) if models else true_model
    if first is None:
        raise ValueError("plot_bode needs at least one model")
    l, m = first.l, first.m
    onames, inames = _names(first, output_names, input_names, l, m)
    fig = new_figure((4.5 * l * m + 1.0, 6.0))
    axes = [[fig.add_subplot(2, l * m, 1 + k + r * l * m) for k in range(l * m)] for r in range(2)]
    curves = list(models.items())
    if true_model is not None:
        curves.append(("true", true_model))
    for c, (label, mod) in enumerate(curves):
        G = mod.frequency_response(w)
        style = {"color": "k", "ls": "--", "lw": 1.2} if label == "true" else {"color": f"C{c}"}
        for i in range(l):
            for j in range(m):
                k = i * m + j
                g = G[i, j]
                axes[0][k].semilogx(
                    w, 20 * np.log10(np.maximum(np.abs(g), 1e-300)), label=label, **style
                )
                axes[1][k].semilogx(w, np.degrees(np.unwrap(np.angle(g))), **style)
                axes[0][k].set_title(f"{inames[j]} -> {onames[i]}")
    for k in range(l * m):
        axes[0][k].set_ylabel("|G| [dB]")
        axes[1][k].set_ylabel("phase [deg]")
        axes[1][k].set_xlabel(f"frequency [rad/{first.time_unit}]")
        for r in range(2):
            axes[r][k].grid(True, which="both", alpha=0.3)
    axes[0][0].legend(fontsize="small")
    fig.suptitle(title)
    return fig


def plot_eigenvalue_scatter(
    groups: dict[str, Any],
    true: Any | None = None,
    zoom: float | None = 1.5,
    title: str = "Identified eigenvalues",
    time_unit: str = "s",
) -> Any:
    """One panel per group of Monte Carlo eigenvalues (dots) with the true ones (circles).

    Parameters
    ----------
    groups : dict of str to array_like
        Label (e.g. a method) -> complex eigenvalues of all runs pooled.
    true : array_like of complex, optional
        The true eigenvalues.
    zoom : float or None, optional
        The axes span the truth's bounding box widened by ``zoom * max |true|`` (points
        outside are counted in the panel title); ``None``: autoscale.
    title : str, optional
        The figure's title.
    time_unit : str, optional
        The axes are in rad per this unit.

    Returns
    -------
    matplotlib.figure.Figure
        The figure.
    """
    k = max(len(groups), 1)
    fig = new_figure((4.2 * k, 4.2))
    tv = None if true is None else np.asarray(true, dtype=complex).ravel()
    for n, (label, ev) in enumerate(groups.items()):
        ax = fig.add_subplot(1, k, n + 1)
        ev = np.asarray(ev, dtype=complex).ravel()
        ev = ev[np.isfinite(ev)]
        outside = 0
        if tv is not None and zoom is not None:
            r = zoom * float(np.max(np.abs(tv)))
            x0, x1 = tv.real.min() - r, tv.real.max() + r
            y0, y1 = tv.imag.min() - r, tv.imag.max() + r
            inside = (ev.real >= x0) & (ev.real <= x1) & (ev.imag >= y0) & (ev.imag <= y1)
            outside = int(np.sum(~inside))
            ax.set_xlim(x0, x1)
            ax.set_ylim(y0, y1)
            ev = ev[inside]
        ax.plot(ev.real, ev.imag, ".", ms=3, alpha=0.5, color=f"C{n}", label="identified")
        if tv is not None:
            ax.plot(tv.real, tv.imag, "o", mfc="none", mec="k", ms=10, mew=1.5, label="true")
        ax.axvline(0.0, color="0.6", lw=0.8)
        ax.axhline(0.0, color="0.6", lw=0.8)
        ax.set_xlabel(f"Re [rad/{time_unit}]")
        ax.set_ylabel(f"Im [rad/{time_unit}]")
        ax.set_title(f"{label}" + (f"\n({outside} outside the view)" if outside else ""))
        ax.legend(loc="upper right", fontsize="small")
        ax.grid(True, alpha=0.3)
    fig.suptitle(title)
    return fig


def plot_outputs(
    t: Any,
    measured: Any,
    simulated: dict[str, Any],
    output_names: list[str] | None = None,
    title: str = "Measured and simulated outputs",
    window: tuple[float, float] | None = None,
    time_unit: str = "s",
) -> Any:
    """Measured outputs (grey) with one or more simulated ones.

    Parameters
    ----------
    t : array_like, shape (Ns,)
        Sample times.
    measured : array_like, shape (Ns, l)
        Measured outputs.
    simulated : dict of str to array_like
        Label -> simulated outputs of shape ``(Ns, l)``.
    output_names : list of str, optional
        Channel names (default ``y1, ...``).
    title : str, optional
        The figure's title.
    window : tuple of two float, optional
        Restricts the time axis (a few seconds are readable, a long record is not).
    time_unit : str, optional
        Labels the time axis.

    Returns
    -------
    matplotlib.figure.Figure
        One row per output.
    """
    t = np.asarray(t, dtype=float).ravel()
    y = np.asarray(measured, dtype=float).reshape(t.size, -1)
    l = y.shape[1]
    names = output_names or [f"y{i + 1}" for i in range(l)]
    fig = new_figure((10.0, 2.6 * l + 0.8))
    sel = slice(None)
    if window is not None:
        sel = (t >= window[0]) & (t <= window[1])
    for i in range(l):
        ax = fig.add_subplot(l, 1, i + 1)
        ax.plot(t[sel], y[sel, i], color="0.6", lw=0.8, label="measured")
        for c, (label, ys) in enumerate(simulated.items()):
            ys = np.asarray(ys, dtype=float).reshape(t.size, -1)
            ax.plot(t[sel], ys[sel, i], color=f"C{c}", lw=1.0, label=label)
        ax.set_ylabel(names[i])
        ax.legend(loc="upper right", fontsize="small")
        ax.grid(True, alpha=0.3)
    ax.set_xlabel(f"time [{time_unit}]")
    fig.suptitle(title)
    return fig


# -- validation (Ljung, System Identification, sec. 16.6; MATLAB compare + resid) ---------
def plot_validation(
    model: StateSpaceModel,
    t: Any,
    u: Any,
    y: Any,
    k: int | None = None,
    report: Any | None = None,
    max_lag: int = 25,
    output_names: list[str] | None = None,
    input_names: list[str] | None = None,
    title: str | None = None,
) -> Any:
    r"""Validation figure of a model on a record.

    * per output: measured vs simulated (:meth:`StateSpaceModel.compare`, initial state by
      least squares) and, with ``k``, the ``k``-step-ahead prediction, fits in the legend;
    * per output: autocorrelation of the one-step prediction errors over lags ``1..M`` with
      the 99 % band :math:`\pm 2.58/\sqrt N` and the Ljung-Box verdict;
    * per output and input: residual-input cross-correlation over lags ``-M..M`` with its
      99 % band (:mod:`hdpbsid.models.assessment`; Ljung, *System Identification*, 2nd ed.,
      1999, sec. 16.6).

    Parameters
    ----------
    model : StateSpaceModel
        The model.
    t : array_like, shape (Ns,)
        Sample times.
    u : array_like, shape (Ns, m)
        Input.
    y : array_like, shape (Ns, l)
        Measured output.
    k : int, optional
        Also draw the ``k``-step-ahead prediction.
    report : ResidualReport, optional
        Residual tests already computed (else :meth:`StateSpaceModel.residuals`).
    max_lag : int, optional
        ``M`` when the report is computed here.
    output_names, input_names : list of str, optional
        Channel names (default the model's).
    title : str, optional
        The figure's title.

    Returns
    -------
    matplotlib.figure.Figure
        The figure; the time axis carries the model's ``time_unit``.

    Raises
    ------
    ValueError
        If the record fails :func:`hdpbsid.data.checks.check_data` or ``max_lag`` is out of
        range.
    """
    t, u, y = check_data(t, u, y)
    l, m = y.shape[1], u.shape[1]
    onames, inames = _names(model, output_names, input_names, l, m)
    if report is None:
        report = model.residuals(t, u, y, max_lag=max_lag)
    sim = model.compare(t, u, y)
    pred = model.compare(t, u, y, k=k) if k is not None else None
    fig = new_figure((3.6 * (3 + m), 2.8 * l + 0.8))
    gs = fig.add_gridspec(l, 3 + m)
    for i in range(l):
        ax = fig.add_subplot(gs[i, :2])
        ax.plot(t, y[:, i], color="0.6", lw=0.8, label="measured")
        ax.plot(t, sim.y_hat[:, i], color="C0", lw=1.0, label=f"simulated, fit {sim.fit[i]:.1f} %")
        if pred is not None:
            label = f"{pred.kind}, fit {pred.fit[i]:.1f} %"
            ax.plot(t, pred.y_hat[:, i], color="C1", lw=0.9, label=label)
        ax.set_ylabel(onames[i])
        ax.set_xlabel(f"time [{model.time_unit}]")
        ax.legend(loc="upper right", fontsize="small")
        ax.grid(True, alpha=0.3)
        ax = fig.add_subplot(gs[i, 2])
        ax.bar(report.lags[1:], report.autocorrelation[1:, i], width=0.6, color="C0")
        ax.axhspan(-report.band, report.band, color="C2", alpha=0.2, label="99 % band")
        verdict = "white" if report.white_per_output[i] else "NOT white"
        ax.set_title(
            f"e({onames[i]}) autocorrelation\nQ = {report.ljung_box[i]:.1f} "
            f"(99 %: {report.ljung_box_threshold:.1f}): {verdict}",
            fontsize="small",
        )
        ax.set_xlabel("lag")
        ax.legend(loc="upper right", fontsize="small")
        for j in range(m):
            ax = fig.add_subplot(gs[i, 3 + j])
            ax.bar(report.cross_lags, report.cross_correlation[:, i, j], width=0.6, color="C1")
            b = report.cross_band[i, j]
            ax.axhspan(-b, b, color="C2", alpha=0.2)
            ok = "independent" if report.independent_per_pair[i, j] else "NOT independent"
            ax.set_title(
                f"e({onames[i]}) vs {inames[j]} cross-correlation\n"
                f"zeta = {report.cross_statistic[i, j]:.1f} "
                f"(99 %: {report.cross_threshold[i, j]:.1f}): {ok}",
                fontsize="small",
            )
            ax.set_xlabel("lag")
    fig.suptitle(title or f"Validation: method {model.report.method or '?'!r}, order {model.n}")
    return fig
