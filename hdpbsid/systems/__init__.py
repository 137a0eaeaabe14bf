"""Simulated systems with known truth, for tests, studies and benchmarks.

:mod:`~hdpbsid.systems.linear` holds the linear benchmark systems and data generators
(second-order system, the PBSID toolbox's closed-loop MIMO example, ZOH simulation,
noise at a given SNR); :mod:`~hdpbsid.systems.quadrotor` the closed-loop quadrotor pitch
model (ANT-X drone at hover) with its cascaded controller.  Every generator takes a
``numpy.random.Generator``.
"""

from hdpbsid.systems.linear import (
    add_noise,
    pbsid_example,
    random_steps,
    second_order,
    simulate_discrete,
    simulate_pbsid_closed_loop,
    simulate_zoh,
)

__all__ = [
    "second_order",
    "pbsid_example",
    "simulate_pbsid_closed_loop",
    "simulate_discrete",
    "simulate_zoh",
    "random_steps",
    "add_noise",
]
