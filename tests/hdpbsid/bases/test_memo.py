"""Content-keyed memoisation of the order-independent steps (hdpbsid.bases.memo)."""

import numpy as np
import pytest

from hdpbsid.bases.memo import clear_caches, memoize


def test_cache_is_keyed_on_contents_not_identity():
    calls = []

    @memoize
    def f(a, k=1):
        calls.append(1)
        return a * k

    a = np.arange(5.0)
    r1 = f(a, k=2)
    assert f(a.copy(), k=2) is r1 and len(calls) == 1  # same contents: cached
    a[0] = 10.0  # a caller reusing its buffer must not get the old result
    assert f(a, k=2)[0] == 20.0 and len(calls) == 2
    assert f(a, k=3)[0] == 30.0 and len(calls) == 3  # other keyword: recomputed


def test_cached_results_are_read_only():
    @memoize
    def g(a):
        return (a + 1.0, [a * 2.0])

    out = g(np.ones(3))
    with pytest.raises(ValueError):
        out[0][0] = 5.0
    with pytest.raises(ValueError):
        out[1][0][0] = 5.0


def test_bases_are_keyed_on_family_and_exact_mapping():
    """Two bases of one closed-form family with the same mapping share a cache entry
    (orders of an order selection reuse the projection); a scale that differs below
    the precision of the basis's repr does not."""
    import slbasis

    calls = []

    @memoize
    def h(basis):
        calls.append(1)
        return np.array([basis.scale])

    h(slbasis.basis("hermite", 20, (0.0, 1.0), scale=2.0))
    h(slbasis.basis("hermite", 20, (0.0, 1.0), scale=2.0))
    assert len(calls) == 1
    h(slbasis.basis("hermite", 20, (0.0, 1.0), scale=2.0 + 1e-9))
    h(slbasis.basis("laguerre", 20, (0.0, 1.0), scale=2.0))
    assert len(calls) == 3


def test_digest_is_the_contents_shape_and_dtype():
    """Arrays are hashed by their bytes without a copy: a strided view and its contiguous
    copy share a key; the same bytes under another shape or dtype, or one element
    changed, do not."""
    from hdpbsid.bases.memo import digest

    a = np.arange(24.0).reshape(4, 6)
    view = a[:, ::2]
    assert not view.flags.c_contiguous
    assert digest(view) == digest(np.ascontiguousarray(view))
    assert digest(a) != digest(a.reshape(6, 4))  # same bytes, another shape
    assert digest(a) != digest(a.view(np.int64))  # same bytes, another dtype
    b = a.copy()
    b[3, 5] = np.nextafter(b[3, 5], np.inf)  # one ulp in the last element
    assert digest(a) != digest(b)
    assert digest(np.zeros(0)) == digest(np.zeros(0)) != digest(np.zeros((0, 1)))


def test_clear_caches_empties_every_memoised_function():
    calls = []

    @memoize
    def f(a):
        calls.append("f")
        return a + 1

    @memoize(size=3)
    def g(a):
        calls.append("g")
        return a - 1

    a = np.arange(3.0)
    f(a), g(a), f(a), g(a)
    assert calls == ["f", "g"]
    clear_caches()
    f(a), g(a)
    assert calls == ["f", "g", "f", "g"]  # both computed again


def test_shared_basis_is_one_object_per_arguments_and_its_values_are_read_only():
    import numpy as np
    import pytest

    import slbasis
    from hdpbsid.bases.basis_domain import basis_values, shared_basis

    a = shared_basis("laguerre", 40, (0.0, 10.0), scale=2.0)
    assert shared_basis("laguerre", 40, (0.0, 10.0), scale=2.0) is a
    assert shared_basis("laguerre", 40, (0.0, 10.0), scale=3.0) is not a
    # the same functions as a basis built afresh, to the last bit
    fresh = slbasis.basis("laguerre", 40, (0.0, 10.0), scale=2.0)
    v = basis_values(a, (0.0, 10.0))
    np.testing.assert_array_equal(v, fresh.eval(np.array([0.0, 10.0])))
    with pytest.raises(ValueError):
        v[0, 0] = 1.0  # shared between the orders of a sweep: never modified
