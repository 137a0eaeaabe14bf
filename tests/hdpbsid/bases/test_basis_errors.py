"""Bad input to the basis-domain methods: clear errors naming the argument."""

from __future__ import annotations

import numpy as np
import pytest
from basis_data import make_data

from hdpbsid.methods.hermite import identify_hermite
from hdpbsid.methods.laguerre import identify_laguerre
from hdpbsid.methods.sturm_liouville import identify_legendre

METHODS = [identify_hermite, identify_laguerre, identify_legendre]


@pytest.fixture(scope="module")
def data() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    return make_data(1)


@pytest.mark.parametrize("method", METHODS)
def test_bad_records(method, data) -> None:
    t, u, y = data
    with pytest.raises(ValueError, match="y"):
        method(t, u, np.where(np.arange(t.size) == 7, np.nan, y[:, 0]))
    with pytest.raises(ValueError, match="u"):
        method(t, u[:-1], y)
    t_bad = t.copy()
    t_bad[5] = t_bad[4]
    with pytest.raises(ValueError, match="t"):
        method(t_bad, u, y)
    with pytest.raises(TypeError, match="order"):
        method(t, u, y, order=2.5)
    with pytest.raises(ValueError, match="order"):
        method(t, u, y, order=0)
    with pytest.raises(ValueError, match="identically zero"):
        method(t, np.zeros_like(u), y, order=2)


def test_hermite_basis_too_small_and_p_too_large(data) -> None:
    t, u, y = data
    # 40 s record, bandwidth ~7 rad/s: 30 Hermite functions cover 3.6*30/40 = 2.7 rad/s
    with pytest.raises(ValueError, match="below the data bandwidth"):
        identify_hermite(t, u, y, order=2, N=30)
    with pytest.raises(ValueError, match="p=60 is too large"):
        identify_hermite(t, u, y, order=2, N=200, p=60)
    with pytest.raises(ValueError, match="f <= p"):
        identify_hermite(t, u, y, order=2, p=3, f=4)
    with pytest.raises(ValueError, match="alpha"):
        identify_hermite(t, u, y, order=2, alpha=-1.0)
    with pytest.raises(TypeError, match="beta"):
        identify_hermite(t, u, y, order=2, beta="1")
    with pytest.raises(ValueError, match="exceeds the number of samples"):
        identify_hermite(t[:300], u[:300], y[:300], order=2, N=400)
