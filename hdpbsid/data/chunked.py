"""A uniformly sampled record read in pieces: files larger than memory, Dask arrays.

A :class:`ChunkedRecord` holds a record's length, sampling interval and a reader
``read(a, b) -> (u[a:b], y[a:b])``: an HDF5 file or ``.npy`` memory maps
(:func:`hdpbsid.data.io.open_chunked`), any sliceable arrays such as ``dask.array`` or
``zarr`` (:meth:`ChunkedRecord.from_arrays`).  Nothing is read until a method asks for a
piece; :func:`hdpbsid.methods.chunked.identify_chunked` identifies such a record.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hdpbsid.data.checks import check_positive_int

__all__ = ["ChunkSettings", "CHUNKS", "ChunkedRecord", "CHUNK_SAMPLES"]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class ChunkSettings:
    """How a chunked record is read.

    Attributes
    ----------
    chunk_samples : int
        Samples read and projected per batch of windows.
    """

    #: samples read and projected per batch of windows: about 8 MB per channel, so a batch
    #: of a few channels fits in memory with room while the batches stay few
    chunk_samples: int = 2**20


#: The settings in force.
CHUNKS = ChunkSettings()
#: :attr:`ChunkSettings.chunk_samples` of :data:`CHUNKS`
CHUNK_SAMPLES = CHUNKS.chunk_samples


class _ArrayReader:
    """``read(a, b)`` of sliceable ``u`` (or None), ``y`` (``np.memmap``, ``h5py``
    datasets, ``zarr`` or ``dask`` arrays: anything ``np.asarray(x[a:b])`` accepts)."""

    def __init__(self, u: Any, y: Any) -> None:
        self.u, self.y = u, y

    def __call__(self, a: int, b: int) -> tuple[Array, Array]:
        y = _two_d(np.asarray(self.y[a:b], dtype=float))
        u = np.zeros((b - a, 0)) if self.u is None else _two_d(np.asarray(self.u[a:b], float))
        return u, y


def _two_d(x: Array) -> Array:
    return x[:, None] if x.ndim == 1 else x


@dataclass(frozen=True)
class ChunkedRecord:
    """A uniformly sampled record read in pieces.

    Parameters
    ----------
    read : callable
        ``read(a, b) -> (u, y)``: samples ``a..b-1`` as ``(b - a, m)`` and ``(b - a, l)``
        float arrays.  It must be picklable for ``use_dask`` on a distributed cluster (the
        readers of :func:`hdpbsid.data.io.open_chunked` are).
    ns : int
        Number of samples, at least 3.
    m : int
        Number of inputs, ``>= 0``.
    l : int
        Number of outputs, ``>= 1``.
    dt : float
        Sampling interval, positive and finite.
    t0 : float, optional
        Absolute time of the first sample.

    Attributes
    ----------
    duration : float
        ``(ns - 1) dt``.

    Raises
    ------
    ValueError
        If ``ns < 3``, ``dt`` is not positive and finite, or ``m < 0`` or ``l < 1``.
    TypeError
        If ``ns`` is not an integer or ``dt`` not a number.

    Examples
    --------
    >>> import numpy as np
    >>> rec = ChunkedRecord.from_arrays(np.zeros(1000), np.ones((1000, 2)), dt=0.01)
    >>> rec.m, rec.l, round(rec.duration, 6)
    (1, 2, 9.99)
    >>> [x.shape for x in rec.checked(10, 20)]
    [(10, 1), (10, 2)]
    """

    read: Callable[[int, int], tuple[Array, Array]]
    ns: int
    m: int
    l: int
    dt: float
    t0: float = 0.0

    def __post_init__(self) -> None:
        check_positive_int(self.ns, "ns", 3)
        if isinstance(self.dt, bool) or not isinstance(self.dt, int | float | np.number):
            raise TypeError(f"dt must be a positive number, got {type(self.dt).__name__}")
        if not (np.isfinite(self.dt) and self.dt > 0):
            raise ValueError(f"dt must be a positive finite sampling interval, got {self.dt}")
        if self.l < 1 or self.m < 0:
            raise ValueError(f"need m >= 0 inputs and l >= 1 outputs, got m={self.m}, l={self.l}")

    @classmethod
    def from_arrays(cls, u: Any, y: Any, dt: float, t0: float = 0.0) -> ChunkedRecord:
        """A record over sliceable arrays; nothing is read until identification.

        Parameters
        ----------
        u : array_like, shape (Ns,) or (Ns, m), or None
            Input: ``np.memmap``, ``h5py`` datasets, ``zarr`` or ``dask.array`` arrays, anything
            ``np.asarray(u[a:b])`` accepts; ``None`` for a time series.
        y : array_like, shape (Ns,) or (Ns, l)
            Output, of the same kinds.
        dt : float
            Sampling interval.
        t0 : float, optional
            Absolute time of the first sample.

        Returns
        -------
        ChunkedRecord
            Reading slices of ``u`` and ``y``.

        Raises
        ------
        ValueError
            If ``y`` is not 1-D or 2-D, or ``u`` is not 1-D or 2-D with as many rows as ``y``.
        """
        ys = tuple(np.shape(y))
        if len(ys) not in (1, 2):
            raise ValueError(f"y must be (Ns,) or (Ns, l), got shape {ys}")
        m = 0
        if u is not None:
            us = tuple(np.shape(u))
            if len(us) not in (1, 2) or us[0] != ys[0]:
                raise ValueError(f"u must be (Ns,) or (Ns, m) with Ns = {ys[0]}, got {us}")
            m = 1 if len(us) == 1 else us[1]
        return cls(_ArrayReader(u, y), int(ys[0]), m, 1 if len(ys) == 1 else ys[1], dt, t0)

    @property
    def duration(self) -> float:
        """``(Ns - 1) dt``."""
        return float((self.ns - 1) * self.dt)

    def checked(self, a: int, b: int) -> tuple[Array, Array]:
        """``read(a, b)`` with the shapes and finiteness checked.

        Parameters
        ----------
        a, b : int
            The samples ``a..b-1``.

        Returns
        -------
        u : ndarray, shape (b - a, m)
        y : ndarray, shape (b - a, l)

        Raises
        ------
        ValueError
            If the reader returned other shapes, or a value is NaN or infinite (the message
            gives its sample index).
        """
        u, y = self.read(a, b)
        if u.shape != (b - a, self.m) or y.shape != (b - a, self.l):
            raise ValueError(
                f"the reader returned u {u.shape}, y {y.shape} for samples {a}..{b - 1}; "
                f"expected ({b - a}, {self.m}) and ({b - a}, {self.l})"
            )
        for name, x in (("u", u), ("y", y)):
            if not np.all(np.isfinite(x)):
                k = a + int(np.flatnonzero(~np.isfinite(x).all(axis=1))[0])
                raise ValueError(f"{name} has a NaN or infinite value at sample {k}")
        return u, y
