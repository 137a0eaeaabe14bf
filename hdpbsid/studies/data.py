"""Simulated records for the studies (the thesis, §5: second-order system and closed-loop
quadrotor), with a small per-process cache so that the methods compared on the same
record (same seed, data settings and run) do not simulate it again.

The cache is keyed by the generator's seed entropy and the data settings; the record is
the same whether it comes from the cache or not (the data use the task's generator and
nothing else does), so caching never changes a number.
"""

from __future__ import annotations

import json
from collections import OrderedDict
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hdpbsid.models.model import StateSpaceModel
from hdpbsid.systems import add_noise, second_order
from hdpbsid.systems.quadrotor import (
    PitchData,
    hermite_sweep_excitation,
    simulate_pitch_closed_loop,
)

__all__ = [
    "RecordCacheSettings",
    "RECORD_CACHE",
    "Record",
    "second_order_record",
    "quadrotor_record",
    "SECOND_ORDER_TRUE",
]

Array = NDArray[np.float64]

#: eigenvalues of the second-order benchmark, ``-0.4 +- 1.9596i``
SECOND_ORDER_TRUE = np.linalg.eigvals(second_order()[0])

_CACHE: OrderedDict[str, Any] = OrderedDict()


@dataclass(frozen=True)
class RecordCacheSettings:
    """How many re-simulated records a process keeps.

    Attributes
    ----------
    size : int
        Records kept per process (least recently used dropped first).
    """

    #: records kept per process: the figures of a run re-draw its identification and
    #: validation records from the seed, and a few runs' worth bounds the memory
    size: int = 8


#: The settings in force.
RECORD_CACHE = RecordCacheSettings()


def _cache_key(rng: np.random.Generator, kind: str, settings: dict[str, Any]) -> str | None:
    seq = getattr(rng.bit_generator, "seed_seq", None)
    if seq is None:
        return None
    entropy = seq.entropy
    ent = list(entropy) if isinstance(entropy, list | tuple) else entropy
    spawn = list(getattr(seq, "spawn_key", ()))
    return json.dumps([kind, ent, spawn, settings], sort_keys=True, default=repr)


def _cached(rng: np.random.Generator, kind: str, settings: dict[str, Any], make: Any) -> Any:
    key = _cache_key(rng, kind, settings)
    if key is not None and key in _CACHE:
        _CACHE.move_to_end(key)
        return _CACHE[key]
    value = make()
    if key is not None:
        _CACHE[key] = value
        while len(_CACHE) > RECORD_CACHE.size:
            _CACHE.popitem(last=False)
    return value


_EXCITATIONS: dict[tuple[float, int, float], Array] = {}


def _hermite_sweep_excitation(duration: float, n_max_u: int, amplitude: float) -> Array:
    """The quadrotor's Hermite-projected sweep at 250 Hz over ``duration`` s, computed once
    per process and settings: it is deterministic (no noise), the same for every run and
    SNR, and projecting on ``n_max_u`` Hermite functions cost about a third of a
    record's simulation.  A read-only array, so no caller can alter the cached copy."""
    key = (duration, n_max_u, float(amplitude))
    if key not in _EXCITATIONS:
        ts = 1.0 / 250.0
        t = np.arange(int(round(duration / ts)) + 1) * ts
        exc = hermite_sweep_excitation(t, n_max_u, amplitude=amplitude)
        exc.setflags(write=False)
        _EXCITATIONS[key] = exc
    return _EXCITATIONS[key]


@dataclass(frozen=True)
class Record:
    """A simulated record with its truth.

    Parameters
    ----------
    t : ndarray, shape (Ns,)
        Sample times.
    u : ndarray, shape (Ns, m)
        Input.
    y : ndarray, shape (Ns, l)
        Measured (noisy) output.
    y_clean : ndarray, shape (Ns, l)
        Noise-free output.
    true : ndarray of complex
        The true eigenvalues.
    model : StateSpaceModel
        The true model.
    """

    t: Array
    u: Array
    y: Array
    y_clean: Array
    true: NDArray[np.complex128]
    model: StateSpaceModel


def _hermite_sweep(t: Array, n_max_u: int | None, f0: float, f1: float) -> Array:
    """Unit-amplitude linear sweep ``f0 -> f1`` Hz over the record, projected on
    ``n_max_u`` Hermite functions when given (the thesis, §5)."""
    if n_max_u is None:
        T = float(t[-1] - t[0])
        tt = t - t[0]
        return np.sin(2 * np.pi * (f0 * tt + 0.5 * (f1 - f0) * tt**2 / T))
    return hermite_sweep_excitation(t, int(n_max_u), amplitude=1.0, f0=f0, f1=f1)


def second_order_record(
    rng: np.random.Generator,
    *,
    snr_db: float | None = 20.0,
    samples: int = 4001,
    duration: float = 40.0,
    f0: float = 0.05,
    f1: float = 1.0,
    n_max_u: int | None = 100,
) -> Record:
    """The second-order benchmark (the thesis, sec. 5) excited by a projected sine sweep.

    Parameters
    ----------
    rng : numpy.random.Generator
        Source of the noise.
    snr_db : float or None, optional
        Output SNR in dB on signal power (:func:`hdpbsid.systems.add_noise`); ``None``: no
        noise.
    samples : int, optional
        Uniform samples over ``duration``.
    duration : float, optional
        Record length (s).
    f0, f1 : float, optional
        Band of the linear sweep (Hz).
    n_max_u : int or None, optional
        Hermite functions the sweep is projected on (``None``: the plain sweep).

    Returns
    -------
    Record
        The record (exact first-order-hold response plus noise) and its truth; records are
        cached per process, so the methods compared on one run share it.
    """
    settings = dict(snr_db=snr_db, samples=samples, duration=duration, f0=f0, f1=f1, n=n_max_u)

    def make() -> Record:
        A, B, C, D = second_order()
        true_model = StateSpaceModel(A, B, C, D, np.zeros((2, 1)))
        t = np.linspace(0.0, float(duration), int(samples))
        u = _hermite_sweep(t, n_max_u, f0, f1)[:, None]
        y0 = true_model.simulate(t, u, method="foh")
        y = y0 if snr_db is None else add_noise(y0, float(snr_db), rng)[0]
        return Record(t, u, y, y0, np.linalg.eigvals(A), true_model)

    return _cached(rng, "second_order", settings, make)


def quadrotor_record(
    rng: np.random.Generator,
    *,
    snr_db: float | None = 20.0,
    duration: float = 30.0,
    excitation: str = "sweep",
    outputs: tuple[str, ...] | list[str] = ("q", "theta"),
    amplitude: float = 0.05,
    n_max_u: int | None = None,
) -> PitchData:
    """The closed-loop ANT-X pitch record.

    Simulated by :func:`~hdpbsid.systems.quadrotor.simulate_pitch_closed_loop`.

    Parameters
    ----------
    rng : numpy.random.Generator
        Source of the sensor noise.
    snr_db : float or None, optional
        Sensor SNR in dB (``None``: no noise).
    duration : float, optional
        Record length (s).
    excitation : {"sweep", "3211", "hermite-sweep"}, optional
        ``"hermite-sweep"`` uses :func:`~hdpbsid.systems.quadrotor.hermite_sweep_excitation`
        with ``n_max_u`` terms (the thesis, sec. 5-6); the others the plain signals.
    outputs : sequence of str, optional
        Measured outputs (:func:`~hdpbsid.systems.quadrotor.pitch_output_matrices`).
    amplitude : float, optional
        Peak of the excitation.
    n_max_u : int or None, optional
        Hermite functions of ``"hermite-sweep"``.

    Returns
    -------
    PitchData
        The record and its truth.
    """
    outputs = tuple(outputs)
    settings = dict(
        snr_db=snr_db,
        duration=duration,
        excitation=excitation,
        outputs=list(outputs),
        amplitude=amplitude,
        n=n_max_u,
    )

    def make() -> PitchData:
        exc: Any = excitation
        if excitation == "hermite-sweep":
            exc = _hermite_sweep_excitation(float(duration), int(n_max_u or 300), amplitude)
        return simulate_pitch_closed_loop(
            rng,
            duration=duration,
            snr_db=snr_db,
            excitation=exc,
            outputs=outputs,
            amplitude=amplitude,
        )

    return _cached(rng, "quadrotor", settings, make)


def validation_rng(rng: np.random.Generator) -> np.random.Generator:
    """The validation record's generator: the first child of the task's seed sequence
    (independent noise, reproducible, never the identification record's stream)."""
    seq = rng.bit_generator.seed_seq
    return np.random.default_rng(np.random.SeedSequence(seq.entropy, spawn_key=(1,)))
