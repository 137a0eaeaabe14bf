"""More tools a user might pick, for ``bench/realdata.py``: ARX least squares, and the
PyPI packages ``llsi``, ``pysib`` and ``PSID`` where they import.

Each adapter takes the estimation record (``u (Ns, m)``, ``y (Ns, l)``), an order and
an optional second setting (the input delay ``nk`` for polynomial models, the horizon for
subspace ones) and returns a discrete-time ``peers.Identified`` at the record's rate, so
every tool is scored by the same simulation from a least-squares initial state.

Polynomial models ``y = B(q^-1)/A(q^-1) u`` become state space through
``scipy.signal.tf2ss`` on the coefficients padded to one length (the controllable
canonical form; the direct term is ``b_0``).
"""

from __future__ import annotations

import contextlib
import os
import sys
from collections.abc import Callable, Iterator
from dataclasses import dataclass

import numpy as np
import peers
from cases import Record
from numpy.typing import NDArray
from scipy.signal import tf2ss

Array = NDArray[np.float64]


def _dt(rec: Record) -> float:
    return float(rec.t[1] - rec.t[0])


def poly_to_ss(b: Array, a: Array, dt: float) -> peers.Identified:
    """State space of ``B(q^-1) / A(q^-1)`` (coefficients in powers of ``q^-1``)."""
    length = max(len(a), len(b))
    num = np.concatenate([b, np.zeros(length - len(b))])
    den = np.concatenate([a, np.zeros(length - len(a))])
    A, B, C, D = tf2ss(num, den)
    return peers.Identified(A, B, C, D, dt)


def arx_fit(u: Array, y: Array, na: int, nb: int, nk: int) -> tuple[Array, Array]:
    """Least-squares ARX: ``y_k + a_1 y_{k-1} + ... = b_0 u_{k-nk} + ... + b_{nb-1} u_{k-nk-nb+1}``.

    Returns ``(b, a)`` in powers of ``q^-1`` (``b`` with ``nk`` leading zeros, ``a_0 = 1``).
    """
    u, y = u[:, 0], y[:, 0]
    start = max(na, nk + nb - 1)
    rows = np.arange(start, y.size)
    cols = [-y[rows - i] for i in range(1, na + 1)]
    cols += [u[rows - nk - j] for j in range(nb)]
    theta = np.linalg.lstsq(np.column_stack(cols), y[rows], rcond=None)[0]
    a = np.concatenate([[1.0], theta[:na]])
    b = np.concatenate([np.zeros(nk), theta[na:]])
    return b, a


def _arx(rec: Record, order: int, nk: int | None) -> peers.Identified:
    b, a = arx_fit(rec.u, rec.y, order, order, 1 if nk is None else nk)
    return poly_to_ss(b, a, _dt(rec))


@contextlib.contextmanager
def _quiet_stdout() -> Iterator[None]:
    """Silence file descriptor 1 (pysib's compiled core prints its iterations there)."""
    sys.stdout.flush()
    saved = os.dup(1)
    with open(os.devnull, "w") as null:
        os.dup2(null.fileno(), 1)
        try:
            yield
        finally:
            os.dup2(saved, 1)
            os.close(saved)


def _pysib_oe(rec: Record, order: int, nk: int | None) -> peers.Identified:
    import pysib

    with _quiet_stdout():
        _, m = pysib.oe(rec.u[:, 0], rec.y[:, 0], order, order, 1 if nk is None else nk)
    return poly_to_ss(np.asarray(m["B"], float), np.asarray(m["F"], float), _dt(rec))


def _llsi(method: str) -> Callable[[Record, int, int | None], peers.Identified]:
    def run(rec: Record, order: int, _: int | None) -> peers.Identified:
        import llsi

        data = llsi.iddata(rec.y, rec.u, _dt(rec))
        model = getattr(llsi, method)(data, order)
        ss = model if hasattr(model, "A") else model.to_ss()
        return peers.Identified(
            np.atleast_2d(ss.A),
            np.atleast_2d(ss.B),
            np.atleast_2d(ss.C),
            np.atleast_2d(ss.D),
            _dt(rec),
        )

    return run


def _psid(rec: Record, order: int, horizon: int | None) -> peers.Identified:
    from PSID import IPSID

    i = 10 if horizon is None else horizon
    s = IPSID(rec.y, Z=None, U=rec.u, nx=order, n1=0, i=i)
    D = s.D if getattr(s, "D", None) is not None else np.zeros((rec.y.shape[1], rec.u.shape[1]))
    return peers.Identified(
        np.atleast_2d(s.A), np.atleast_2d(s.B), np.atleast_2d(s.C), np.atleast_2d(D), _dt(rec)
    )


@dataclass(frozen=True)
class Peer:
    """A tool: its adapter, label, the second setting's default and grid (``None``: none)."""

    run: Callable[[Record, int, int | None], peers.Identified]
    label: str
    default: int | None
    grid: tuple[int | None, ...]


#: The tools added here, keyed as in the table.
PEERS: dict[str, Peer] = {
    "arx": Peer(_arx, "ARX least squares (na = nb = order, nk)", 1, (0, 1)),
    "pysib-oe": Peer(_pysib_oe, "pysib OE (nb = nf = order, nk)", 1, (0, 1)),
    "llsi-n4sid": Peer(_llsi("n4sid"), "llsi N4SID", None, (None,)),
    "llsi-pem": Peer(_llsi("pem"), "llsi PEM (state space, N4SID start)", None, (None,)),
    "psid": Peer(_psid, "PSID (IPSID, n1 = 0, horizon i)", 10, (5, 10, 20, 40)),
}


def available() -> list[str]:
    """Keys of :data:`PEERS` whose package imports here."""
    out = []
    for key, mod in (
        ("arx", None),
        ("pysib-oe", "pysib"),
        ("llsi-n4sid", "llsi"),
        ("llsi-pem", "llsi"),
        ("psid", "PSID"),
    ):
        if mod is None:
            out.append(key)
            continue
        try:
            __import__(mod)
        except Exception:  # noqa: BLE001 - any import failure means "not here"
            continue
        out.append(key)
    return out
