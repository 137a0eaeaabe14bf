"""Drift modes (:mod:`hdpbsid.selection.drift`): a mode slower than the record resolves
that the input drives less than the noise.  Oracles: the frequency response of a first-
and a second-order system (the steady-state amplitude of a sinusoid through it), a slow
mode the input cannot reach (``B`` row zero) against one it drives (an integrator-like
gain), and the invariance of modes under a change of state coordinates."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hdpbsid.models.model import StateSpaceModel
from hdpbsid.selection.drift import drift_modes, input_driven_rms, undriven_modes


def _model(A, B, C) -> StateSpaceModel:
    A, B, C = (np.atleast_2d(np.asarray(M, dtype=float)) for M in (A, B, C))
    return StateSpaceModel(
        A, B, C, np.zeros((C.shape[0], B.shape[1])), np.zeros((A.shape[0], C.shape[0]))
    )


def _sine(w: float, T: float = 300.0, h: float = 0.001) -> tuple[np.ndarray, np.ndarray]:
    t = np.arange(0.0, T, h)
    return t, np.sin(w * t)[:, None]


def test_a_first_order_mode_carries_its_frequency_response() -> None:
    """``2 / (s + 1)`` driven by ``sin(2 t)``: amplitude ``2 / sqrt(5)``, RMS that over
    root two."""
    t, u = _sine(2.0)
    lam, rms = input_driven_rms(_model([[-1.0]], [[2.0]], [[1.0]]), t, u)
    expected = 2.0 / np.sqrt(5.0) / np.sqrt(2.0)
    # the zero-state transient decays in a few seconds of the 300 s record, and the held
    # sine differs from the sine by O(w h) = 0.2 %
    assert lam[0] == -1.0
    assert abs(rms[0, 0] / expected - 1.0) < 0.01


def test_a_pair_reports_its_real_output_for_each_member() -> None:
    """``w0^2 / (s^2 + 2 zeta w0 s + w0^2)`` (``w0 = 3``, ``zeta = 0.2``) at ``w = 2``:
    each member of the pair reports the RMS of the pair's real output, the whole output
    here."""
    w0, zeta, w = 3.0, 0.2, 2.0
    A = [[0.0, 1.0], [-(w0**2), -2 * zeta * w0]]
    t, u = _sine(w)
    _, rms = input_driven_rms(_model(A, [[0.0], [w0**2]], [[1.0, 0.0]]), t, u)
    gain = w0**2 / abs(complex(w0**2 - w**2, 2 * zeta * w0 * w))
    # as above: the transient decays in ~2 s, the hold's error is O(w h)
    np.testing.assert_allclose(rms[:, 0], gain / np.sqrt(2.0), rtol=0.01)


def _slow_record(b_slow: float, seed: int = 0) -> tuple[tuple, StateSpaceModel]:
    """A model with a fast mode ``-2`` and a slow one (``-0.01``: ``|lambda| T = 1 < 2
    pi`` over 100 s) that the input drives through ``b_slow``, and a record of it: a
    random binary input held 1 s, the exact sampled response plus 1 % white noise."""
    rng = np.random.default_rng(seed)
    h, n = 0.01, 10_000
    t = np.arange(n) * h
    u = np.repeat(rng.choice([-1.0, 1.0], n // 100), 100)[:, None]
    model = _model([[-2.0, 0.0], [0.0, -0.01]], [[1.0], [b_slow]], [[1.0, 1.0]])
    a = np.exp(np.diag(model.A) * h)
    g = (a - 1.0) / np.diag(model.A) * model.B[:, 0]
    x, y = np.zeros(2), np.empty(n)
    for k in range(n):
        y[k] = model.C[0] @ x
        x = a * x + g * u[k, 0]
    return (t, u, (y + 0.01 * rng.standard_normal(n))[:, None]), model


def test_a_slow_mode_the_input_does_not_reach_is_a_drift() -> None:
    rec, model = _slow_record(0.0)
    assert drift_modes(model, rec) == 1


def test_a_slow_mode_the_input_drives_is_not_a_drift() -> None:
    """The same slow mode reached by the input (gain ``1 / 0.01``, an integrator over the
    record): it carries the input's effect far above the 1 % noise."""
    rec, model = _slow_record(1.0)
    assert drift_modes(model, rec) == 0


def test_fast_modes_are_never_a_drift() -> None:
    """Over a record 100 s long, ``-2`` completes far more than ``2 pi`` of decay: it is
    resolved whatever drives it."""
    rec, _ = _slow_record(0.0)
    model = _model([[-2.0, 0.0], [0.0, -5.0]], [[1.0], [0.0]], [[1.0, 1.0]])
    assert drift_modes(model, rec) == 0


@settings(max_examples=20, deadline=None)
@given(st.lists(st.floats(-2.0, 2.0), min_size=4, max_size=4))
def test_the_count_does_not_depend_on_the_state_coordinates(entries: list[float]) -> None:
    """Modes, their input-output paths and the one-step errors are invariant under
    ``x -> T x``; so is the count."""
    T = np.eye(2) + 0.4 * np.reshape(entries, (2, 2))
    if abs(np.linalg.det(T)) < 0.2:  # keep T well conditioned: the property, not rounding
        T = np.eye(2)
    Ti = np.linalg.inv(T)
    for b_slow, expected in ((0.0, 1), (1.0, 0)):
        rec, m = _slow_record(b_slow)
        moved = _model(T @ m.A @ Ti, T @ m.B, m.C @ Ti)
        assert drift_modes(moved, rec) == expected


@pytest.mark.parametrize(("noise_ratio", "expected"), [(0.5, False), (2.0, True)])
def test_a_mode_is_undriven_below_the_noise_at_any_speed(noise_ratio, expected) -> None:
    """``2 / (s + 5)`` driven by ``sin(2 t)`` (RMS ``2 / sqrt(29) / sqrt(2)``, its
    frequency response) in white noise at ``noise_ratio`` times that RMS: the model's
    one-step errors (``K = 0``) are the noise, so the mode is undriven exactly when the
    noise is the larger.  A fast mode, never a drift."""
    t, u = _sine(2.0, T=100.0, h=0.01)
    model = _model([[-5.0]], [[2.0]], [[1.0]])
    rms = 2.0 / np.sqrt(29.0) / np.sqrt(2.0)
    rng = np.random.default_rng(0)
    y = model.simulate(t, u) + noise_ratio * rms * rng.standard_normal((t.size, 1))
    # a factor of two either side: the noise's sample RMS over 10^4 samples is within 2 %
    assert undriven_modes(model, (t, u, y)).tolist() == [expected]
    assert drift_modes(model, (t, u, y)) == 0


def test_undriven_modes_cannot_be_judged_without_an_input() -> None:
    t, u = _sine(2.0, T=10.0, h=0.01)
    model = _model([[-5.0]], np.zeros((1, 0)), [[1.0]])
    assert undriven_modes(model, (t, u[:, :0], np.zeros((t.size, 1)))) is None
