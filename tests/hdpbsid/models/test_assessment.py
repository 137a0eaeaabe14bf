"""Model validation (hdpbsid.models.assessment, model.compare / residuals, validate command)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from scipy.stats import chi2

from hdpbsid.cli import main, model_from_dict, model_to_dict, write_model_json
from hdpbsid.identify import identify
from hdpbsid.models.assessment import fit_percent, residual_tests
from hdpbsid.models.model import LinearTrend, StateSpaceModel
from hdpbsid.plots import plot_validation, save_figure
from hdpbsid.systems import add_noise, random_steps, second_order, simulate_zoh

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def _record(seed: int, snr_db: float = 20.0, duration: float = 100.0):
    """Second-order system (known truth), random steps, white output noise.

    N = 2000 samples at 0.05 s: the 99 % band is 2.58 / sqrt(2000) = 0.058, and at 20 dB
    an order-1 model leaves the unmodelled 2 rad/s resonance in its residuals at ~10 times
    the noise power, whose autocorrelation is far outside that band (measured Q ~ 1e3
    against the threshold 44), while for the true model the residuals are the white noise
    itself (Q ~ chi2(25), mean 25).
    """
    A, B, C, D = second_order()
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, duration, 0.05)
    u = random_steps(rng, t, hold=0.5)
    y, _ = add_noise(simulate_zoh(A, B, C, D, t, u), snr_db, rng)
    # measurement noise only: the true innovation model has K = 0
    truth = StateSpaceModel(A, B, C, D, np.zeros((2, 1)))
    return t, u, y, truth


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_true_model_passes_and_order_one_fails_whiteness(seed: int) -> None:
    t, u, y, truth = _record(seed)
    rep = truth.residuals(t, u, y)
    assert rep.white and rep.independent, rep.summary()
    wrong = identify(t, u, y, order=1, method="dt")
    bad = wrong.residuals(t, u, y)
    assert not bad.white, bad.summary()
    # the order-1 residuals miss the resonance by far, not by a hair
    assert bad.ljung_box[0] > 5 * bad.ljung_box_threshold, bad.summary()
    # and the compare fit tells the same story
    assert truth.compare(t, u, y).fit[0] > wrong.compare(t, u, y).fit[0] + 10


def test_ljung_box_statistic_against_a_direct_formula_and_its_level() -> None:
    rng = np.random.default_rng(0)
    n, M = 1000, 20
    e = rng.standard_normal(n)
    rep = residual_tests(e, None, max_lag=M)
    # independent computation: numpy.correlate and the Ljung-Box (1978) formula
    full = np.correlate(e, e, mode="full")[n - 1 :] / n
    r = full[1 : M + 1] / full[0]
    Q = n * (n + 2) * np.sum(r**2 / (n - np.arange(1, M + 1)))
    assert rep.ljung_box[0] == pytest.approx(Q, rel=1e-12)  # same sums: rounding only
    assert rep.ljung_box_threshold == pytest.approx(chi2.ppf(0.99, M))
    assert rep.band == pytest.approx(2.5758293 / np.sqrt(n), rel=1e-7)
    # level: white noise is rejected in ~1 % of 300 records (Binomial(300, 0.01): mean 3,
    # P(X > 10) = 3e-4); an AR(1) with coefficient 0.3 is rejected every time (its lag-1
    # correlation 0.3 is 9.5 standard errors at N = 1000)
    u = rng.standard_normal((n, 1))
    white, indep = 0, 0
    for _ in range(300):
        w = rng.standard_normal(n)
        rr = residual_tests(w, u, max_lag=M)
        white += not rr.white
        indep += not rr.independent
    assert white <= 10 and indep <= 10, (white, indep)
    ar = np.zeros(n)
    for _ in range(20):
        w = rng.standard_normal(n)
        for k in range(1, n):
            ar[k] = 0.3 * ar[k - 1] + w[k]
        assert not residual_tests(ar, None, max_lag=M).white


def test_cross_correlation_detects_an_input_leak() -> None:
    rng = np.random.default_rng(3)
    n = 1000
    u = rng.standard_normal((n, 1))
    e = rng.standard_normal(n)
    e[3:] += 0.3 * u[:-3, 0]  # residual still holds the input delayed by 3 samples
    rep = residual_tests(e, u, max_lag=10)
    assert not rep.independent
    k = int(np.argmax(np.abs(rep.cross_correlation[:, 0, 0])))
    assert rep.cross_lags[k] == 3
    # white e, white u: Ljung's P = 1 and the cross band equals the autocorrelation band
    # (P estimated from 21 sample correlations of size 1/sqrt(N): within ~15 %)
    rep0 = residual_tests(rng.standard_normal(n), u, max_lag=10)
    assert rep0.cross_band[0, 0] == pytest.approx(rep0.band, rel=0.15)


def test_compare_fit_and_prediction() -> None:
    t, u, y, truth = _record(0, snr_db=200.0, duration=20.0)
    # noise-free up to 1e-10 relative: the truth fits to rounding of the ZOH simulation
    assert truth.compare(t, u, y).fit[0] == pytest.approx(100.0, abs=1e-6)
    assert truth.compare(t, u, y, k=5).fit[0] == pytest.approx(100.0, abs=1e-6)
    # fit_percent is MATLAB's definition: a constant prediction at the mean scores 0 %
    assert fit_percent(y, np.full_like(y, y.mean()))[0] == pytest.approx(0.0, abs=1e-12)
    with pytest.raises(ValueError, match="k must be an integer >= 1"):
        truth.compare(t, u, y, k=0)
    with pytest.raises(ValueError, match="max_lag must be between"):
        truth.residuals(t, u, y, max_lag=t.size)


def test_model_json_round_trip_keeps_everything() -> None:
    A, B, C, D = second_order()
    m = StateSpaceModel(
        A,
        B,
        C,
        D,
        np.array([[0.1], [0.2]]),
        singular_values=np.array([3.0, 2.0, 0.1]),
        options={"method": "x"},
        noise_covariance=np.array([[0.01]]),
        u0=[1.5],
        y0=[-2.0],
        trend=LinearTrend(3.0, [0.1], [-0.2]),
    )
    m2 = model_from_dict(json.loads(json.dumps(model_to_dict(m))))
    for k in ("A", "B", "C", "D", "K", "u0", "y0", "noise_covariance", "singular_values"):
        np.testing.assert_array_equal(getattr(m2, k), getattr(m, k))
    assert m2.trend.t_ref == 3.0
    np.testing.assert_array_equal(m2.trend.y_slope, [-0.2])
    t = np.linspace(0.0, 5.0, 101)
    u = np.sin(t)[:, None] + 1.5
    np.testing.assert_array_equal(m2.simulate(t, u), m.simulate(t, u))
    with pytest.raises(ValueError, match="lacks the entry 'K'"):
        model_from_dict({k: v for k, v in model_to_dict(m).items() if k != "K"})


def test_validate_command_and_figure(tmp_path: Path, capsys) -> None:
    t, u, y, truth = _record(1)
    truth.options["columns"] = {"time": "t", "inputs": ["force"], "outputs": ["pos"]}
    model_path = write_model_json(truth, tmp_path / "model.json")
    wrong = identify(t, u, y, order=1, method="dt")
    wrong.options["columns"] = truth.options["columns"]
    wrong_path = write_model_json(wrong, tmp_path / "wrong.json")
    data = tmp_path / "val.csv"
    np.savetxt(data, np.c_[t, u, y], delimiter=",", header="t,force,pos", comments="", fmt="%.17g")
    out = tmp_path / "out"
    assert main(["validate", str(model_path), str(data), "--k", "3", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "fit pos (simulation" in text and "3-step-ahead prediction" in text
    assert "-> white" in text and "-> independent" in text
    png = (out / "validation.png").read_bytes()
    assert png[:8] == PNG_MAGIC and len(png) > 1000
    assert main(["validate", str(wrong_path), str(data), "--no-plot", "--out", str(out)]) == 0
    assert "NOT white" in capsys.readouterr().out
    assert main(["validate", str(tmp_path / "none.json"), str(data)]) == 2
    assert "model file not found" in capsys.readouterr().err
    assert main(["validate", str(model_path), str(data), "--outputs", "t"]) == 2
    fig = plot_validation(truth, t, u, y, k=2)
    assert save_figure(fig, tmp_path / "v.png").read_bytes()[:8] == PNG_MAGIC
