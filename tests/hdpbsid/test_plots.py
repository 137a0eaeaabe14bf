"""Figures and printed summaries: what they show is what the model and its checks hold.

Oracles: the fit of MATLAB's ``compare`` written out with numpy, the standard error of a
table built from a known one, and the selection table the figure is drawn from.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

import hdpbsid
from hdpbsid.plots import display_fit, order_criterion, plot_identification


@pytest.fixture(scope="module")
def record():
    """A lightly damped second-order system, 30 s at 20 ms, SNR about 30 dB."""
    A = [[0.0, 1.0], [-4.0, -0.8]]
    B, C, D = [[0.0], [1.0]], [[1.0, 0.0]], [[0.0]]
    rng = np.random.default_rng(3)
    t = np.arange(0.0, 30.0, 0.02)
    u = np.convolve(rng.standard_normal(t.size), np.ones(10) / 10, mode="same")
    _, y, _ = signal.lsim((A, B, C, D), u, t)
    y = y + 0.03 * y.std() * rng.standard_normal(t.size)
    return t, u, y


@pytest.fixture(scope="module")
def chosen(record):
    """A model whose order was chosen on held-out data (the table the figure draws)."""
    t, u, y = record
    return hdpbsid.identify(t, u, y, method="laguerre", refine=None, max_order=4)


def _nrmse_fit(y: np.ndarray, y_hat: np.ndarray) -> float:
    return 100.0 * (1.0 - np.linalg.norm(y - y_hat) / np.linalg.norm(y - y.mean()))


def test_fit_is_the_compare_fit(chosen, record) -> None:
    t, u, y = record
    res = chosen.fit(t, u, y)
    assert res.fit[0] == pytest.approx(_nrmse_fit(y, res.y_sim[:, 0]), abs=1e-9)  # rounding
    assert chosen.compare(t, u, y).fit[0] == pytest.approx(res.fit[0], abs=1e-9)  # same path
    shown = display_fit(chosen, t, u, y)
    assert shown.fit[0] == pytest.approx(res.fit[0], abs=1e-9)  # stable: the same simulation
    # the summaries print the fit and no array
    for text in (repr(res), repr(shown)):
        assert "fit=" in text and "vaf" not in text.lower() and "\n" not in text
        assert f"{res.fit[0]:.2f}" in text


def test_order_criterion_recovers_a_known_standard_error() -> None:
    se, errors = 0.02, {1: 0.9, 2: 0.31, 3: 0.30, 4: 0.305}
    best = min(errors.values())
    table = [
        {"method": "m", "order": o, "error": e, "z": (e - best) / se} for o, e in errors.items()
    ]
    table.append({"method": "m", "order": 2, "error": None, "z": None, "status": "failed"})
    orders, err, got = order_criterion(table)
    assert orders.tolist() == [1, 2, 3, 4] and err.tolist() == list(errors.values())
    assert got == pytest.approx(se, rel=1e-12)  # rounding of (e - best) / z * z
    assert order_criterion("singular values of the method") is None
    assert order_criterion([]) is None


def test_identification_figure_shows_what_decided(chosen, record) -> None:
    t, u, y = record
    table = chosen.options["order_selection"]
    orders, errors, se = order_criterion(table)
    assert se is not None and se > 0
    fig = plot_identification(chosen, t, u, y)
    by_title = {a.get_title(): a for a in fig.axes}
    ax = by_title["Order: held-out prediction error"]
    xs, ys = ax.lines[0].get_data()
    np.testing.assert_array_equal(xs, orders)
    # per order, the best candidate of the selection table above the best of all, in
    # standard errors; the order chosen is the smallest within one of them
    for o, v in zip(orders, ys, strict=True):
        e = min(r["error"] for r in table if r["order"] == o and r["error"] is not None)
        assert v == pytest.approx((e - errors.min()) / se, rel=1e-12, abs=1e-12)  # rounding
    assert chosen.n == min(o for o, v in zip(orders, ys, strict=True) if v <= 1.0)
    legend = [x.get_text() for x in ax.get_legend().get_texts()]
    assert "chosen" in legend and "best + 1 SE" in legend
    chosen_marker = [ln for ln in ax.lines if ln.get_label() == "chosen"][0]
    assert chosen_marker.get_xdata()[0] == chosen.n
    assert "Singular values of the subspace step" in by_title
    assert {"Bode magnitude", "Bode phase"} <= set(by_title)
    phase = by_title["Bode phase"].lines[0].get_ydata()
    w = by_title["Bode phase"].lines[0].get_xdata()
    G = chosen.frequency_response(w)[0, 0]
    np.testing.assert_allclose(phase, np.degrees(np.unwrap(np.angle(G))), atol=1e-9)
    texts = " ".join(
        x.get_text() for a in fig.axes if a.get_legend() for x in a.get_legend().get_texts()
    )
    assert f"fit {chosen.fit(t, u, y).fit[0]:.1f} %" in texts and "VAF" not in texts


def test_given_order_draws_a_note_not_a_criterion(record) -> None:
    t, u, y = record
    m = hdpbsid.identify(t, u, y, order=2, method="laguerre", refine=None)
    fig = plot_identification(m, t, u, y)
    assert "Order: held-out prediction error" not in {a.get_title() for a in fig.axes}


def test_residual_report_prints_a_summary(chosen, record) -> None:
    t, u, y = record
    rep = chosen.residuals(t, u, y, max_lag=20)
    text = repr(rep)
    assert "\n" not in text and len(text) < 300
    assert f"white: {int(rep.white)}/1 outputs" in text
    assert f"{rep.ljung_box[0]:.1f}" in text
