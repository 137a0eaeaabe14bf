"""The library owns its threads (:mod:`slbasis.runtime`): the BLAS limits are in force
inside the public calls, restored after them, and the caller's override wins.

Every test first sets the caller's BLAS threads explicitly (``threadpool_limits(OUTER)``,
which OpenBLAS honours even when ``OPENBLAS_NUM_THREADS=1`` was set at start-up), so a
test process started with one thread cannot make "limited to one" or "restored" hold by
accident.
"""

from __future__ import annotations

import numpy as np
import pytest
from threadpoolctl import threadpool_info, threadpool_limits

import hdpbsid
import slbasis.runtime as runtime
from hdpbsid.bases.memo import clear_caches
from hdpbsid.methods.dt import identify_dt
from hdpbsid.methods.registry import METHODS
from hdpbsid.systems import second_order, simulate_zoh

#: the caller's BLAS threads in these tests: above one, whatever the machine
OUTER = 3


def _blas_counts() -> set[int]:
    """Thread counts of every loaded BLAS library, read by threadpoolctl itself (an
    oracle independent of :func:`slbasis.runtime.blas_threads`)."""
    return {int(i["num_threads"]) for i in threadpool_info() if i["user_api"] == "blas"}


def _record(seed: int = 0, n: int = 600):
    A, B, C, D = second_order()
    rng = np.random.default_rng(seed)
    t = np.arange(n) * 0.01
    u = rng.standard_normal(n)
    return t, u, simulate_zoh(A, B, C, D, t, u)


@pytest.fixture
def spy_method(monkeypatch):
    """A registered method that records the BLAS threads it runs with, then identifies."""
    seen: list[set[int]] = []

    def spy(t, u, y, order=None, **options):
        seen.append(_blas_counts())
        return identify_dt(t, u, y, order=order, **options)

    monkeypatch.setitem(METHODS, "thread-spy", spy)
    return seen


def test_identify_runs_with_one_blas_thread_and_restores(spy_method):
    t, u, y = _record()
    with threadpool_limits(OUTER):
        assert _blas_counts() == {OUTER}
        model = hdpbsid.identify(t, u, y, order=2, method="thread-spy", refine=None)
        assert _blas_counts() == {OUTER}
    assert spy_method == [{1}]
    assert model.n == 2


def test_limits_restored_when_the_call_raises(monkeypatch):
    def boom(t, u, y, order=None, **options):
        raise RuntimeError(f"inside with {sorted(_blas_counts())}")

    monkeypatch.setitem(METHODS, "thread-boom", boom)
    t, u, y = _record()
    with threadpool_limits(OUTER):
        with pytest.raises(RuntimeError, match=r"inside with \[1\]"):
            hdpbsid.identify(t, u, y, order=2, method="thread-boom", refine=None)
        assert _blas_counts() == {OUTER}


def test_environment_variable_overrides(spy_method, monkeypatch):
    monkeypatch.setenv(runtime.ENV_VAR, "2")
    t, u, y = _record()
    with threadpool_limits(OUTER):
        hdpbsid.identify(t, u, y, order=2, method="thread-spy", refine=None)
        assert _blas_counts() == {OUTER}
    assert spy_method == [{2}]


def test_context_manager_wins_over_environment(spy_method, monkeypatch):
    monkeypatch.setenv(runtime.ENV_VAR, "2")
    t, u, y = _record()
    with threadpool_limits(OUTER), hdpbsid.num_threads(4):
        hdpbsid.identify(t, u, y, order=2, method="thread-spy", refine=None)
        assert runtime.compiled_threads() == 4
    assert spy_method == [{4}]


@pytest.mark.parametrize("bad", ["0", "-1", "two", "1.5"])
def test_bad_environment_value_names_the_variable(monkeypatch, bad):
    monkeypatch.setenv(runtime.ENV_VAR, bad)
    with pytest.raises(ValueError, match=runtime.ENV_VAR):
        runtime.requested_threads()


@pytest.mark.parametrize("bad", [0, -2, 1.5, True, "3"])
def test_bad_argument_raises(bad):
    with pytest.raises(ValueError, match="positive integer"):
        with runtime.num_threads(bad):
            pass


def test_model_simulation_is_limited(monkeypatch):
    import hdpbsid.models.model as model_module

    seen: list[set[int]] = []
    original = model_module.linear_recursion

    def spy(*args, **kwargs):
        seen.append(_blas_counts())
        return original(*args, **kwargs)

    monkeypatch.setattr(model_module, "linear_recursion", spy)
    A, B, C, D = second_order()
    model = hdpbsid.StateSpaceModel(A, B, C, D, np.zeros((A.shape[0], C.shape[0])))
    t, u, _ = _record()
    with threadpool_limits(OUTER):
        model.simulate(t, u)
        assert _blas_counts() == {OUTER}
    assert seen and all(s == {1} for s in seen)


def test_large_work_gets_the_callers_threads(monkeypatch):
    """A QR of the core above the size threshold runs with the caller's threads, every
    other BLAS call of the same identification with one (threshold lowered so that a
    small record has both kinds)."""
    import hdpbsid.core.blocks as blocks

    seen: list[tuple[int, set[int]]] = []
    original = blocks.dgeqrf

    def spy(A, *args, **kwargs):
        seen.append((A.shape[0] * A.shape[1] ** 2, _blas_counts()))
        return original(A, *args, **kwargs)

    monkeypatch.setattr(blocks, "dgeqrf", spy)
    t, u, y = _record()
    clear_caches()  # the QRs of the core are memoised: run them afresh
    with threadpool_limits(OUTER):
        hdpbsid.identify(t, u, y, order=2, method="hermite", refine=None)
    sizes = sorted(s for s, _ in seen)
    assert len(sizes) >= 2 and sizes[0] < sizes[-1]
    # the threshold between the smallest and the largest QR of the call
    threshold = 2.0 * (sizes[0] + sizes[-1]) / 2
    monkeypatch.setattr(runtime, "LARGE_FLOPS", threshold)
    seen.clear()
    clear_caches()
    with threadpool_limits(OUTER):
        hdpbsid.identify(t, u, y, order=2, method="hermite", refine=None)
    for size, counts in seen:
        assert counts == ({OUTER} if 2.0 * size >= threshold else {1}), size


def test_large_work_respects_a_callers_limit():
    @runtime.library_call
    def inside():
        with runtime.large_work(runtime.LARGE_FLOPS):
            large = _blas_counts()
        with runtime.large_work(runtime.LARGE_FLOPS / 2):
            small = _blas_counts()
        return large, small

    with threadpool_limits(OUTER):
        assert inside() == ({OUTER}, {1})
    with threadpool_limits(1):
        assert inside() == ({1}, {1})


def test_large_work_outside_library_calls_changes_nothing():
    with threadpool_limits(OUTER):
        with runtime.large_work(10 * runtime.LARGE_FLOPS):
            assert _blas_counts() == {OUTER}


def test_nested_calls_keep_the_outer_limit_until_the_outermost_returns():
    @runtime.library_call
    def inner():
        return _blas_counts()

    @runtime.library_call
    def outer():
        before = _blas_counts()
        got = inner()
        return before, got, _blas_counts()

    with threadpool_limits(OUTER):
        assert outer() == ({1}, {1}, {1})
        assert _blas_counts() == {OUTER}


def test_projection_threads_follow_the_override(monkeypatch):
    from slbasis.numeric import engine

    with runtime.num_threads(3):
        assert engine._threads() == 3
    monkeypatch.setenv(runtime.ENV_VAR, "1")
    assert engine._threads() == 1


def test_warnings_name_the_users_line() -> None:
    """A warning raised deep inside the library (here the basis-size cap, three library
    frames below the call) is attributed to this file, the caller's; a fixed
    ``stacklevel`` names the caller at one depth only."""
    import warnings

    from hdpbsid.bases.family import size_policy
    from hdpbsid.bases.hermite_family import HermiteFamily

    size = size_policy(HermiteFamily(), None, 1000.0)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        size(1e6, 10**7)  # the rule asks for far more functions than the cap
    assert caught, "the size cap binds and must warn"
    assert {w.filename for w in caught} == {__file__}


def test_a_call_that_imports_leaves_no_library_scan_to_the_next(monkeypatch):
    # the scan of the loaded libraries (threadpoolctl's controller) is redone when modules
    # were imported since the last one; modules imported inside a call are scanned when
    # it returns, so the next call starts without that one-off cost
    import sys
    import types

    import threadpoolctl

    built = []
    original = threadpoolctl.ThreadpoolController.__init__

    def counting(self, *args, **kwargs):
        built.append(1)
        original(self, *args, **kwargs)

    monkeypatch.setattr(threadpoolctl.ThreadpoolController, "__init__", counting)
    name = "_slbasis_runtime_test_module"

    @runtime.library_call
    def importing():
        sys.modules[name] = types.ModuleType(name)  # stands in for a lazy import

    try:
        importing()
        before = len(built)
        importing()  # nothing imported since the first call returned
        assert len(built) == before
    finally:
        sys.modules.pop(name, None)


def test_the_model_does_not_depend_on_the_number_of_threads() -> None:
    """The projection's lanes are fixed by the call's size (slbasis.numeric.engine), the
    small-matrix work runs on one BLAS thread: the same record gives the same model bit
    for bit on one and on two threads (10^4 samples: several lanes; with 4000 the
    projection is one lane, and per-thread sums passed too)."""
    from slbasis.numeric import engine

    if engine._disabled():
        pytest.skip("SLBASIS_NO_NUMBA set: the numpy engine has no threads")
    t, u, y = _record(3, 10000)
    models = []
    for n in (1, 2):
        clear_caches()  # the second call must project again, not reuse the first's rows
        with runtime.num_threads(n):
            models.append(hdpbsid.identify(t, u, y, order=2, method="hermite"))
    for name in "ABCDK":
        np.testing.assert_array_equal(getattr(models[1], name), getattr(models[0], name))
