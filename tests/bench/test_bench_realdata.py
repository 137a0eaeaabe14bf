"""The scorer of the measured-data benchmark (``bench/realdata.py``).

Oracle: a noise-free record of a known system in *periodic steady state* under a
zero-mean multisine whose period divides both the estimation and the validation part.
Its estimation means are then exactly zero (the sum of a sinusoid over whole periods
vanishes, and so does the periodic response of a system with no input DC), so the true
model must reproduce the validation part exactly, and a model with zero output must
score exactly 0 %.  The data are sampled with ``scipy.signal.cont2discrete``, not with the
code under test.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.signal import cont2discrete

BENCH = Path(__file__).resolve().parents[2] / "bench"
sys.path.insert(0, str(BENCH))

import peers  # noqa: E402
import realdata  # noqa: E402

DT = 0.1
PERIOD = 60  # samples; divides the estimation (600) and validation (300) parts
NS = 900
# a lightly damped pair and a real pole, with a zero: x' = A x + B u, y = C x
A = np.array([[0.0, 1.0, 0.0], [-4.0, -0.4, 1.0], [0.0, 0.0, -3.0]])
B = np.array([[0.0], [1.0], [2.0]])
C = np.array([[1.0, 0.5, 0.0]])
D = np.zeros((1, 1))


def _periodic_record() -> tuple[np.ndarray, np.ndarray]:
    """``u, y (NS, 1)``: multisine at 1, 3 and 7 cycles per period, system in its
    periodic steady state from the first sample on."""
    k = np.arange(NS)
    u = sum(np.cos(2 * np.pi * f * k / PERIOD + f) for f in (1, 3, 7))[:, None]
    Ad, Bd, Cd, Dd, _ = cont2discrete((A, B, C, D), DT, method="zoh")
    # state after one period from x = 0, then the fixed point x0 = Ad^P x0 + x_forced
    x = np.zeros(3)
    for j in range(PERIOD):
        x = Ad @ x + Bd @ u[j]
    x0 = np.linalg.solve(np.eye(3) - np.linalg.matrix_power(Ad, PERIOD), x)
    y = np.empty((NS, 1))
    x = x0
    for j in range(NS):
        y[j] = Cd @ x + Dd @ u[j]
        x = Ad @ x + Bd @ u[j]
    return u, y


def test_split_takes_two_thirds_and_the_estimation_means() -> None:
    rng = np.random.default_rng(1)
    u, y = rng.standard_normal((1000, 1)) + 3.0, rng.standard_normal((1000, 1)) - 2.0
    s = realdata.split_record(u, y, 0.1)
    assert s.estimation.t.size == 666 and s.validation.t.size == 334  # floor(2000 / 3)
    # the offsets are the means of the first 666 rows, applied to both parts
    np.testing.assert_array_equal(s.u_offset, u[:666].mean(axis=0))
    np.testing.assert_array_equal(s.validation.y, y[666:] - y[:666].mean(axis=0))
    np.testing.assert_allclose(s.validation.t[0], 66.6, rtol=1e-12)  # one clock, dt apart


def test_true_model_scores_100_percent() -> None:
    u, y = _periodic_record()
    split = realdata.split_record(u, y, DT)
    # the construction makes the estimation means vanish up to rounding of O(1) sums
    assert np.max(np.abs(split.y_offset)) < 1e-12 and np.max(np.abs(split.u_offset)) < 1e-12
    model = peers.Identified(A, B, C, D)  # continuous: the scorer ZOH-samples it
    # identical ZOH recursions up to the rounding of expm vs cont2discrete: ~1e-12 relative
    assert realdata.validation_fit(model, split) > 100 - 1e-6
    Ad, Bd, Cd, Dd, _ = cont2discrete((A, B, C, D), DT, method="zoh")
    discrete = peers.Identified(Ad, Bd, Cd, Dd, DT)  # a discrete peer's model at the rate
    assert realdata.validation_fit(discrete, split) > 100 - 1e-6
    # a model whose output is identically zero is no better than the mean, which is 0
    # over whole periods: fit exactly 0 up to rounding
    zero = peers.Identified(A, B, np.zeros_like(C), D)
    assert abs(realdata.validation_fit(zero, split)) < 1e-9


def test_a_wrong_model_scores_lower() -> None:
    u, y = _periodic_record()
    split = realdata.split_record(u, y, DT)
    slower = peers.Identified(0.7 * A, 0.7 * B, C, D)  # same DC gain, modes 30 % slower
    fit = realdata.validation_fit(slower, split)
    assert np.isfinite(fit) and fit < 90  # a 30 % frequency shift of a resonance is visible


def test_fit_is_invariant_to_offsets_on_input_and_output() -> None:
    u, y = _periodic_record()
    rng = np.random.default_rng(3)
    noisy = y + 0.05 * rng.standard_normal(y.shape)  # any record, not only exact ones
    models = [
        peers.Identified(A, B, C, D),
        peers.Identified(0.8 * A, B, C, D),
    ]
    for model in models:
        base = realdata.validation_fit(model, realdata.split_record(u, noisy, DT))
        shifted = realdata.validation_fit(model, realdata.split_record(u + 7.0, noisy - 3.0, DT))
        # the centred records differ only by the rounding of adding/removing 7 and 3
        assert shifted == pytest.approx(base, abs=1e-8)


def test_discrete_model_at_another_rate_is_rejected() -> None:
    u, y = _periodic_record()
    split = realdata.split_record(u, y, DT)
    model = peers.Identified(np.eye(3) * 0.5, B, C, D, dt=2 * DT)
    with pytest.raises(ValueError, match="dt"):
        realdata.discrete_matrices(model, split.dt)


@pytest.mark.parametrize(
    ("name", "ns", "dt"), [("robot-arm", 1024, 1.0), ("ball-and-beam", 1000, 0.1)]
)
def test_records_have_the_documented_size(name: str, ns: int, dt: float) -> None:
    # sizes and sampling times as DaISy documents them (bench/data/README.md)
    u, y, rec_dt = realdata.load_record(name)
    assert u.shape == (ns, 1) and y.shape == (ns, 1) and rec_dt == dt
    assert np.all(np.isfinite(u)) and np.all(np.isfinite(y))


def test_unknown_record_is_rejected() -> None:
    with pytest.raises(ValueError, match="record"):
        realdata.load_record("no-such-record")
