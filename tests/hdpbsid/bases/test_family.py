"""The basis-family seam and the pipeline's blocks (``hdpbsid.bases.family``, ``.pipeline``)."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from hdpbsid.bases.family import Choice, size_policy
from hdpbsid.bases.hermite_family import HermiteFamily
from hdpbsid.bases.pipeline import make_blocks, one_or_all
from hdpbsid.bases.sl_family import SturmLiouvilleFamily
from hdpbsid.data.records import as_records


def test_size_policy_applies_the_band_rule_and_checks_a_given_size() -> None:
    fam = HermiteFamily()
    # Hermite rule N = 2 wb T / 3.6: wb = 10 rad/s over 40 s asks for ceil(800 / 3.6)
    assert size_policy(fam, None, 10.0)(40.0, 4001).value == math.ceil(800 / 3.6)
    assert size_policy(fam, 300, 10.0)(40.0, 4001) == Choice(300, "given")
    with pytest.raises(ValueError, match="below the data bandwidth"):
        size_policy(fam, 100, 10.0)(40.0, 4001)  # 3.6 * 100 / 40 = 9 rad/s < 10
    with pytest.raises(ValueError, match="exceeds the number of samples"):
        size_policy(fam, 300, 10.0)(40.0, 200)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        # the rule asks for 223 but 201 samples resolve at most Ns/2 = 100 functions
        assert size_policy(fam, None, 10.0)(40.0, 201).value == 100
    assert any("Ns/2" in str(w.message) for w in caught)


def test_windows_of_one_length_share_one_basis() -> None:
    t = np.arange(0.0, 120.0 + 1e-9, 0.05)
    rng = np.random.default_rng(0)
    u, y = rng.standard_normal((t.size, 1)), rng.standard_normal((t.size, 1))
    fam = SturmLiouvilleFamily("legendre")
    blocks = make_blocks(
        as_records(t, u, y), fam, 30.0, lambda: (None, {}), size_policy(fam, 80, 1.0)
    )
    # 120 s in windows of 30 s: four windows of 601 samples on one relative time axis
    assert len(blocks.segs) == 4 and set(blocks.keys) == {0}
    assert len({id(b) for b in blocks.seg_bases}) == 1
    opts = blocks.options()
    assert opts["N_per_block"] == [80] * 4 and opts["N_rule"] == "given"
    assert opts["n_samples"] == t.size


def test_one_or_all() -> None:
    assert one_or_all(["a", "a"]) == "a"
    assert one_or_all([1.0, 2.0]) == [1.0, 2.0]


def test_hermite_lag_survives_pickle() -> None:
    """A lag operator travels to other processes (Dask) by pickle: the copy applies the
    same ``W D'^{-1}`` bit for bit (same LU factors, same LAPACK call)."""
    import pickle

    from hdpbsid.bases.hermite_family import _derivative_matrix, hermite_lag

    lag, _ = hermite_lag(_derivative_matrix(40, 2.0, None), 3.0, 1.0, 1.0)
    copy = pickle.loads(pickle.dumps(lag))
    W = np.random.default_rng(0).standard_normal((3, 40))
    np.testing.assert_array_equal(copy.apply(W, 2), lag.apply(W, 2))
