"""Figures for identified models (matplotlib, Agg; no windows are ever opened).

Issue 4, item 7: the CLI writes a figure with the singular values (order selection),
measured vs simulated output and the Bode magnitude.  Figures are built on
:class:`matplotlib.figure.Figure` with an Agg canvas, never through ``pyplot``, so the
library neither changes the global backend nor keeps figures alive.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .model import StateSpaceModel, fit_statistics
from .validation import check_data

__all__ = [
    "new_figure",
    "plot_identification",
    "plot_eigenvalues",
    "save_figure",
    "display_fit",
    "DisplayFit",
]


@dataclass
class DisplayFit:
    """Simulated output for display: ``y_sim (Ns, l)``, ``vaf`` (percent per output) and
    ``kind`` describing how it was obtained (see :func:`display_fit`)."""

    y_sim: NDArray[np.float64]
    vaf: NDArray[np.float64]
    kind: str


def display_fit(
    model: StateSpaceModel, t: Any, u: Any, y: Any, growth: float = 100.0
) -> DisplayFit:
    """Measured-vs-simulated fit that stays meaningful for open-loop *unstable* models.

    A stable model is simulated over the whole record (:meth:`StateSpaceModel.fit`,
    initial state by least squares).  A free-run simulation of an unstable model (the
    quadrotor's ``+3.08`` pole: ``e^{3.08 * 30}`` ~ 1e40 over a 30 s flight) diverges even
    for the true model, so the record is cut into segments over which the fastest
    unstable mode grows by at most ``growth`` (``T_seg = ln(growth) / max Re(lambda)``)
    and each segment is simulated from its own least-squares initial state.
    """
    t, u, y = check_data(t, u, y)
    max_re = float(np.max(model.eigenvalues.real)) if model.n else -1.0
    if max_re <= 0:
        fit = model.fit(t, u, y)
        return DisplayFit(fit.y_sim, fit.vaf, "simulation (x0 estimated)")
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
        y_sim, vaf, f"simulation on segments of length {t_seg:.3g}, x0 estimated per segment"
    )


def new_figure(figsize: tuple[float, float] = (10.0, 8.0)) -> Any:
    """A :class:`matplotlib.figure.Figure` attached to an Agg canvas."""
    try:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
    except ImportError as exc:  # pragma: no cover - matplotlib is in the plots extra
        raise ImportError("plots need matplotlib: pip install 'slbasis-hdpbsid[plots]'") from exc
    fig = Figure(figsize=figsize, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def save_figure(fig: Any, path: str | Path, dpi: int = 110) -> Path:
    """Write ``fig`` as an image (format from the suffix, PNG by default); returns the path."""
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
    """Three-panel summary: singular values, measured vs simulated outputs, Bode magnitude.

    * singular values of the PBSID SVD step (log scale) with the chosen order marked;
    * each output measured vs simulated (:func:`display_fit`: whole record for a stable
      model, short segments for an unstable one), VAF in the legend;
    * ``|G(jw)|`` in dB for every input-output pair (``w`` rad/s; default from the record
      length to Nyquist), dashed for ``true_model`` if given.

    Returns the :class:`matplotlib.figure.Figure` (save it with :func:`save_figure`).
    """
    t, u, y = check_data(t, u, y)
    l = y.shape[1]
    m = u.shape[1]
    onames = output_names or [f"y{i + 1}" for i in range(l)]
    inames = input_names or [f"u{j + 1}" for j in range(m)]
    fig = new_figure((10.0, 3.0 + 2.2 * l))
    gs = fig.add_gridspec(l + 1, 2)

    ax = fig.add_subplot(gs[0, 0])
    sv = model.singular_values
    if sv is not None and np.size(sv):
        sv = np.asarray(sv, dtype=float)
        idx = np.arange(1, sv.size + 1)
        ax.semilogy(idx, sv, "o-", ms=3)
        ax.axvline(model.n + 0.5, color="C3", ls="--", label=f"order {model.n}")
        ax.legend(loc="upper right")
    else:
        ax.text(0.5, 0.5, "no singular values recorded", ha="center", transform=ax.transAxes)
    ax.set_xlabel("index")
    ax.set_ylabel("singular value")
    ax.set_title("Order selection")

    ax = fig.add_subplot(gs[0, 1])
    if m:
        wgrid = _default_frequencies(model, t) if w is None else np.asarray(w, dtype=float)
        G = model.frequency_response(wgrid)
        Gt = true_model.frequency_response(wgrid) if true_model is not None else None
        k = 0
        for i in range(l):
            for j in range(m):
                mag = 20 * np.log10(np.maximum(np.abs(G[i, j]), 1e-300))
                ax.semilogx(wgrid, mag, color=f"C{k % 10}", label=f"{inames[j]} -> {onames[i]}")
                if Gt is not None:
                    magt = 20 * np.log10(np.maximum(np.abs(Gt[i, j]), 1e-300))
                    ax.semilogx(wgrid, magt, color=f"C{k % 10}", ls="--", lw=1)
                k += 1
        ax.legend(fontsize="small")
    else:
        ax.text(0.5, 0.5, "no inputs", ha="center", transform=ax.transAxes)
    ax.set_xlabel("frequency [rad/s]")
    ax.set_ylabel("|G| [dB]")
    ax.set_title("Bode magnitude" + (" (dashed: true)" if true_model is not None else ""))

    fit = display_fit(model, t, u, y)
    for i in range(l):
        ax = fig.add_subplot(gs[i + 1, :])
        ax.plot(t, y[:, i], color="0.6", lw=0.8, label="measured")
        ax.plot(t, fit.y_sim[:, i], color="C0", lw=1.0, label=f"simulated, VAF {fit.vaf[i]:.1f} %")
        ax.set_ylabel(onames[i])
        ax.legend(loc="upper right", fontsize="small")
        if i == l - 1:
            ax.set_xlabel(f"time ({fit.kind})")
    method = model.options.get("method", "?")
    fig.suptitle(title or f"hdpbsid: method {method!r}, order {model.n}")
    return fig


def plot_eigenvalues(identified: Any, true: Any | None = None, title: str = "Eigenvalues") -> Any:
    """Identified (crosses) and true (circles) eigenvalues in the complex plane."""
    fig = new_figure((5.5, 4.5))
    ax = fig.add_subplot(1, 1, 1)
    ev = np.asarray(identified, dtype=complex).ravel()
    if true is not None:
        tv = np.asarray(true, dtype=complex).ravel()
        ax.plot(tv.real, tv.imag, "o", mfc="none", ms=10, label="true")
    ax.plot(ev.real, ev.imag, "x", ms=8, mew=2, label="identified")
    ax.axvline(0.0, color="0.5", lw=0.8)
    ax.axhline(0.0, color="0.5", lw=0.8)
    ax.set_xlabel("Re")
    ax.set_ylabel("Im")
    ax.set_title(title)
    ax.legend()
    return fig
