"""Method ``"laguerre"``: CT-PBSID with Laguerre functions (Bergamasco & Lovera 2011).

Laguerre functions with pole ``a`` have Laplace transforms
``L_n(s) = sqrt(2a) (s - a)^n / (s + a)^{n+1}``: going from ``n`` to ``n + 1`` is the
all-pass ``w = (s - a)/(s + a)``.  A continuous system ``G(s) = D + C (sI - A)^{-1} B``
is, as a function of ``w``, the discrete transfer function
``Gd(z) = Dd + Cd (zI - Ad)^{-1} Bd`` with ``z = 1/w`` and (bilinear/Cayley map, derived
from ``sI - A = (aI - A)(zI - Ad)/(z - 1)`` at ``s = a (z + 1)/(z - 1)``)

    Ad = (A + aI)(A - aI)^{-1},       Bd = sqrt(2a) (aI - A)^{-1} B,
    Cd = -sqrt(2a) C (aI - A)^{-1},   Dd = D + C (aI - A)^{-1} B,

inverted by :func:`inverse_cayley` (``A = a (Ad + I)(Ad - I)^{-1}``, ...).  A stable
``lambda`` maps inside the unit disc (``|lambda + a| < |lambda - a|`` for ``Re lambda < 0``),
so stability is preserved both ways.  ``Dd != 0`` even when ``D = 0``, so the core runs
with ``feedthrough=True``.

Variants (the thesis, §3.1: the projection is the exact transformation, the filter an
approximation valid as ``t -> inf``):

* ``"projection"`` (Ohta & Kawai 2004; Bergamasco & Lovera 2011): the Laguerre
  coefficients ``<l_n, u>``, ``<l_n, y>`` of the windowed record obey ``Gd`` in the index
  ``n`` (causal, zero initial state), exactly, once the boundary impulses
  ``x(t0) delta(t - t0) - x(tN) delta(t - tN)`` of the windowed state are added as the
  pseudo-inputs ``l_n(t0)``, ``l_n(tN)``; the PBSID core runs with the sample shift in
  ``n``;
* ``"filter"``: the outputs of the Laguerre filter network ``L_n(s)`` applied to ``u`` and
  ``y``, sampled at many times; at every time ``t`` the sequence in ``n`` (the Laguerre
  coefficients of the reversed past) obeys ``Gd`` in the reversed index
  ``N - 1 - n``; blocks of ``N`` columns per time, shifted within blocks.  Initial-state
  transients are not modelled (they decay), so the first ``burn_in`` seconds are skipped.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hdpbsid.bases.basis_domain import (
    P_DEFAULT_RANGE,
    BlockShift,
    CoreOut,
    basis_values,
    best_hold,
    resolve_holds,
    shared_basis,
)
from hdpbsid.bases.family import BasisFamily, size_policy
from hdpbsid.bases.laguerre_pole import decide_pole
from hdpbsid.bases.pipeline import make_blocks, project, solve
from hdpbsid.bases.segments import default_window, records_bandwidth
from hdpbsid.bases.settings import BasisSettings, resolve_settings
from hdpbsid.core.blocks import BlockLag
from hdpbsid.core.varx import SampleShift
from hdpbsid.data.checks import check_order, check_positive_int
from hdpbsid.data.records import Dataset, Record, as_records
from hdpbsid.methods.hermite import _real
from hdpbsid.models.model import StateSpaceModel
from hdpbsid.models.report import Choice
from hdpbsid.runtime import library_call

__all__ = [
    "identify_laguerre",
    "fit_laguerre",
    "LaguerreFamily",
    "laguerre_model",
    "cayley",
    "inverse_cayley",
    "laguerre_filter",
]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class LaguerreSupport:
    """The part of the Laguerre functions' support a record fills (the default basis size
    ``N = 2 a T / support``).

    Attributes
    ----------
    nodes_per_function : float
        The largest node of the first ``N`` Laguerre functions is about this times ``N``.
    fill : float
        The fraction of ``[0, x_N]`` the record fills.

    Examples
    --------
    >>> LaguerreSupport().support
    3.6
    """

    #: the largest zero of the Laguerre polynomial ``L_N`` grows like ``4 N`` (Szego,
    #: *Orthogonal Polynomials*, sec. 6.32): beyond it the functions decay
    nodes_per_function: float = 4.0
    #: a margin: the record ends inside the support, so that its end is still resolved by
    #: the highest functions, not left to their decaying tails
    fill: float = 0.9

    @property
    def support(self) -> float:
        """``nodes_per_function * fill``, in units of ``2 a T / N``."""
        return self.nodes_per_function * self.fill


#: Laguerre functions: largest node ``x_N ~ 4 N``; record fills 90 % of ``[0, x_N]``
LAGUERRE_SUPPORT = LaguerreSupport().support

#: the settings the candidates of an order/method sweep are fitted with
#: (:func:`hdpbsid.selection.candidates.sweep_settings`): the bandwidth pole, the first
#: pass of the default.  The method judges no setting on held-out data, so the chosen
#: candidate's refit keeps this pole too: the predictor the held-out part judged.
SWEEP_SETTINGS: dict[str, Any] = {"a": "bandwidth"}
N_MIN, N_MAX = 100, 4000  # the upper limit bounds the cost (clip_basis_size warns)


def cayley(A: Array, B: Array, C: Array, D: Array, a: float) -> tuple[Array, Array, Array, Array]:
    r"""Continuous ``(A, B, C, D)`` to the Laguerre-domain ``(Ad, Bd, Cd, Dd)``.

    Laguerre functions of pole ``a`` go from index ``n`` to ``n + 1`` by the all-pass
    ``w = (s - a) / (s + a)``, so the continuous transfer function is, in ``z = 1 / w``, the
    discrete one of the bilinear (Cayley) images; a stable ``lambda`` maps inside the unit
    disc (module docstring).

    Parameters
    ----------
    A : ndarray, shape (n, n)
        State matrix.
    B : ndarray, shape (n, m)
        Input matrix.
    C : ndarray, shape (l, n)
        Output matrix.
    D : ndarray, shape (l, m)
        Feedthrough.
    a : float
        The Laguerre pole, ``> 0``.

    Returns
    -------
    Ad : ndarray, shape (n, n)
        ``(A + aI)(A - aI)^{-1}``.
    Bd : ndarray, shape (n, m)
        ``sqrt(2a) (aI - A)^{-1} B``.
    Cd : ndarray, shape (l, n)
        ``-sqrt(2a) C (aI - A)^{-1}``.
    Dd : ndarray, shape (l, m)
        ``D + C (aI - A)^{-1} B`` (non-zero even when ``D = 0``).

    Notes
    -----
    .. math::

        A_d = (A + aI)(A - aI)^{-1},\quad B_d = \sqrt{2a}\,(aI - A)^{-1} B,\quad
        C_d = -\sqrt{2a}\,C (aI - A)^{-1},\quad D_d = D + C (aI - A)^{-1} B .

    References
    ----------
    .. [1] B. Wahlberg, "System identification using Laguerre models", *IEEE Trans.
       Automatic Control* 36(5), 551-562, 1991.

    Examples
    --------
    >>> from hdpbsid.systems.linear import second_order
    >>> A, B, C, D = second_order()  # eigenvalues -0.4 +- 1.96j
    >>> Ad, Bd, Cd, Dd = cayley(A, B, C, D, a=2.0)
    >>> np.abs(np.linalg.eigvals(Ad)).round(4)  # inside the unit disc
    array([0.8165, 0.8165])
    """
    n = A.shape[0]
    R = np.linalg.inv(a * np.eye(n) - A)
    r = np.sqrt(2 * a)
    Ad = (A + a * np.eye(n)) @ np.linalg.inv(A - a * np.eye(n))
    return Ad, r * R @ B, -r * C @ R, D + C @ R @ B


def inverse_cayley(
    Ad: Array, Bd: Array, Cd: Array, Dd: Array, a: float
) -> tuple[Array, Array, Array, Array]:
    """Inverse of :func:`cayley`: the continuous ``(A, B, C, D)`` of a Laguerre-domain system.

    Parameters
    ----------
    Ad : ndarray, shape (n, n)
        Laguerre-domain state matrix.
    Bd : ndarray, shape (n, m)
        Laguerre-domain input matrix.
    Cd : ndarray, shape (l, n)
        Laguerre-domain output matrix.
    Dd : ndarray, shape (l, m)
        Laguerre-domain feedthrough.
    a : float
        The Laguerre pole, ``> 0``.

    Returns
    -------
    A : ndarray, shape (n, n)
        ``a (Ad + I)(Ad - I)^{-1}``.
    B : ndarray, shape (n, m)
        ``-sqrt(2a) (Ad - I)^{-1} Bd``.
    C : ndarray, shape (l, n)
        ``sqrt(2a) Cd (Ad - I)^{-1}``.
    D : ndarray, shape (l, m)
        ``Dd - Cd (Ad - I)^{-1} Bd``.

    Raises
    ------
    ValueError
        If ``Ad`` has an eigenvalue at 1 (the image of ``s = infinity``; condition number
        of ``Ad - I`` above ``1e12``).

    Examples
    --------
    >>> from hdpbsid.systems.linear import second_order
    >>> A, B, C, D = second_order()
    >>> A2, B2, C2, D2 = inverse_cayley(*cayley(A, B, C, D, 2.0), 2.0)
    >>> bool(np.allclose(A2, A) and np.allclose(B2, B) and np.allclose(C2, C))
    True
    """
    n = Ad.shape[0]
    Q = Ad - np.eye(n)
    if np.linalg.cond(Q) > 1e12:
        raise ValueError(
            "the identified Laguerre-domain A has an eigenvalue at 1 (s = infinity): no "
            "continuous-time model; try another order or Laguerre pole a"
        )
    Qi = np.linalg.inv(Q)
    r = np.sqrt(2 * a)
    A = a * (Ad + np.eye(n)) @ Qi
    return A, -r * Qi @ Bd, r * Cd @ Qi, Dd - Cd @ Qi @ Bd


def laguerre_filter(t: Array, x: Array, a: float, N: int) -> Array:
    """Outputs of the Laguerre network ``L_n(s)``, ``n < N``, for each column of ``x``.

    The network ``L_n(s) = sqrt(2a) (s - a)^n / (s + a)^{n+1}`` has the state-space form
    ``xi' = F xi + sqrt(2a) 1 x`` with ``F`` lower triangular (``-a`` on the diagonal,
    ``-2a`` below), simulated exactly for ``x`` linear between samples, from rest.

    Parameters
    ----------
    t : ndarray, shape (Ns,)
        Sample times.
    x : ndarray, shape (Ns, k)
        The signals.
    a : float
        The Laguerre pole, ``> 0``.
    N : int
        Number of filters.

    Returns
    -------
    ndarray, shape (Ns, k, N)
        The filter outputs.

    References
    ----------
    .. [1] B. Wahlberg, "System identification using Laguerre models", *IEEE Trans.
       Automatic Control* 36(5), 551-562, 1991.

    Examples
    --------
    A unit step settles at the DC gains ``L_n(0) = sqrt(2 / a) (-1)^n``:

    >>> t = np.linspace(0.0, 10.0, 1001)
    >>> laguerre_filter(t, np.ones((1001, 1)), a=1.0, N=3)[-1, 0].round(4)
    array([ 1.4141, -1.4129,  1.4013])
    """
    F = -a * np.eye(N) - 2 * a * np.tril(np.ones((N, N)), -1)
    b = np.full((N, 1), np.sqrt(2 * a))
    net = StateSpaceModel(F, b, np.zeros((1, N)), np.zeros((1, 1)), np.zeros((N, 1)))
    out = np.empty((t.shape[0], x.shape[1], N))
    for k in range(x.shape[1]):
        _, xi = net.simulate(t, x[:, k : k + 1], method="foh", return_states=True)
        out[:, k, :] = xi
    return out


@dataclass(frozen=True)
class LaguerreFamily(BasisFamily):
    """Laguerre functions with pole ``a`` on the window, as a basis family
    (:class:`~hdpbsid.bases.family.BasisFamily`; module docstring, projection variant).

    * size: the record fills 90 % of the support, ``N = 2 a T / 3.6``;
    * lag: the sample shift in the Laguerre index (the all-pass ``(s - a) / (s + a)``);
    * pseudo-inputs: with ``boundary``, the boundary rows ``l_n(0)``, ``l_n(T)``;
    * model: the inverse Cayley map (:func:`inverse_cayley`); the Laguerre-domain ``Dd`` is
      always estimated (``feedthrough=True`` in the core).

    Parameters
    ----------
    a : float
        The Laguerre pole (rad/s), positive.

    Examples
    --------
    >>> fam = LaguerreFamily(2.0)
    >>> fam.wanted_size(9.0, 1.0)  # 2 a T / 3.6, whatever the band
    10.0
    >>> fam.pseudo_rows(fam.basis(20, 9.0), None, True, None).shape
    (2, 20)
    """

    a: float
    label = "laguerre"
    n_min, n_max = N_MIN, N_MAX
    q = (1, 2)
    core_overrides = {"feedthrough": True}
    size_rule = f"record fills 90 % of the support: N = 2aT/{LAGUERRE_SUPPORT}"

    def size_rate(self, wb: float) -> float:
        """``2 a / 3.6`` functions per second, whatever the band.

        Parameters
        ----------
        wb : float
            Data bandwidth (rad/s), unused: the pole sets the band.

        Returns
        -------
        float
            Functions per second of window.
        """
        return 2 * self.a / LAGUERRE_SUPPORT

    def wanted_size(self, T: float, wb: float) -> float:
        """``2 a T / 3.6``: the record fills 90 % of the support of the functions.

        Parameters
        ----------
        T : float
            Window length (s).
        wb : float
            Data bandwidth (rad/s), unused.

        Returns
        -------
        float
            The size the rule wants.
        """
        return 2 * self.a * T / LAGUERRE_SUPPORT

    def basis(self, N: int, T: float) -> Any:
        """:func:`slbasis.basis` ``("laguerre", N, (0, T), scale=2 a)``, shared.

        Parameters
        ----------
        N : int
            Number of functions.
        T : float
            Window length (s).

        Returns
        -------
        Basis
            The Laguerre basis.
        """
        return shared_basis("laguerre", N, (0.0, T), scale=2 * self.a)

    def lag(self, basis: Any, operator: Any) -> SampleShift:
        """The sample shift in the Laguerre index.

        Parameters
        ----------
        basis : Basis
            The block's basis (unused).
        operator : object
            Unused: the Laguerre lag has no operator scale.

        Returns
        -------
        SampleShift
            The shift.
        """
        return SampleShift()

    def pseudo_rows(self, basis: Any, operator: Any, boundary: bool, ones: Any) -> Array:
        """``l_n(0)``, ``l_n(T)`` with ``boundary``, else no rows.

        The windowed state jumps at the window's ends: the impulses ``x(t0) delta(t - t0) -
        x(tN) delta(t - tN)`` project to these rows with unknown factors.

        Parameters
        ----------
        basis : Basis
            The block's basis.
        operator : object
            Unused.
        boundary : bool
            Include the boundary rows.
        ones : object
            Unused.

        Returns
        -------
        ndarray, shape (0 or 2, N)
            The rows.
        """
        if not boundary:
            return np.zeros((0, basis.N))
        return basis_values(basis, (0.0, basis.t_span[1])).T

    def model(
        self,
        out: CoreOut,
        operator: Any,
        options: dict[str, Any],
        *,
        settings: BasisSettings,
        hold: str,
        hold_criterion: dict[str, float],
        order: int | None,
    ) -> StateSpaceModel:
        """The continuous-time model by the inverse Cayley map, with the input hold.

        Parameters
        ----------
        out : CoreOut
            The core's Laguerre-domain system.
        operator : object
            Unused (the pole is the family's).
        options : dict
            The method's options.
        settings : BasisSettings
            The shared settings.
        hold : str
            The input hold used.
        hold_criterion : dict of str to float
            The criterion of each hold tried.
        order : int or None
            The order asked for.

        Returns
        -------
        StateSpaceModel
            The continuous-time model (:func:`laguerre_model`).
        """
        given = settings.input_hold != "auto"
        held = {
            "input_hold": hold,
            "input_hold_rule": "given" if given else "auto: smaller VARX AIC",
            "input_hold_criterion": hold_criterion,
            "projection": "exact integral of the sample interpolants (Gauss nodes)",
        }
        return laguerre_model(out, self.a, {**held, **options}, settings, order)


def laguerre_model(
    out: CoreOut, a: float, options: dict[str, Any], settings: BasisSettings, order: int | None
) -> StateSpaceModel:
    """The continuous-time model of the core's Laguerre-domain system.

    ``(A, B, C, D)`` by :func:`inverse_cayley`; ``K`` mapped back like ``B`` (the
    Laguerre-domain innovation enters ``y`` with a non-identity feedthrough, so ``K`` is
    approximate).

    Parameters
    ----------
    out : CoreOut
        The core's Laguerre-domain system.
    a : float
        The Laguerre pole.
    options : dict
        Options merged over the core's.
    settings : BasisSettings
        The shared settings (``max_order`` reported when the order was selected).
    order : int or None
        The order asked for.

    Returns
    -------
    StateSpaceModel
        The continuous-time model, ``options["A_laguerre"]`` the Laguerre-domain ``A``.

    Raises
    ------
    ValueError
        If the Laguerre-domain ``A`` has an eigenvalue at 1 (:func:`inverse_cayley`).
    """
    A, B, C, D = inverse_cayley(out.A, out.B, out.C, out.D, a)
    n = A.shape[0]
    K = -np.sqrt(2 * a) * np.linalg.solve(out.A - np.eye(n), out.K)
    merged = {**out.options, **options, "A_laguerre": out.A}
    if order is None:
        merged["max_order"] = settings.max_order
    return StateSpaceModel(
        A,
        B,
        C,
        D,
        K,
        singular_values=out.core.singular_values,
        options=merged,
        noise_covariance=out.noise_covariance,
    )


@library_call
def identify_laguerre(
    t: Any,
    u: Any = None,
    y: Any = None,
    order: int | None = None,
    *,
    a: float | str | None = None,
    N: int | None = None,
    variant: str = "projection",
    n_times: int | None = None,
    burn_in: float | None = None,
    settings: BasisSettings | None = None,
    **shared: Any,
) -> StateSpaceModel:
    r"""CT-PBSID (Laguerre): a continuous-time model ``A, B, C, D, K`` from ``t, u, y``.

    The Laguerre coefficients of a record obey the discrete system of the Cayley map in
    the Laguerre index (module docstring), so the PBSID core runs with the sample shift in
    that index and the model maps back by :func:`inverse_cayley`.  Each record, or window
    of a long record, is projected on its own Laguerre basis (common pole ``a``) with its
    own boundary pseudo-inputs, all stacked in one PBSID problem (projection variant).
    Every choice is reported, with its reason, in ``model.options``.

    Parameters
    ----------
    t : array_like, shape (Ns,), or list of records
        Increasing sample times; or a list of ``(t_i, u_i, y_i)`` records (``u = y =
        None``; projection variant).
    u : array_like, shape (Ns, m), optional
        Inputs.
    y : array_like, shape (Ns, l)
        Outputs.
    order : int, optional
        Model order; None: the largest log-gap of the singular values.
    a : float, "bandwidth", "dynamics" or None, optional
        The Laguerre pole (rad per time unit).  ``"bandwidth"``: half the data bandwidth
        (99 % of the input energy, 95 % of the output energy), so the pole sits inside the
        excited band.  ``"dynamics"``: after that first pass, the pole minimising the
        largest map-back amplification of the identified modes
        (:mod:`hdpbsid.bases.laguerre_pole`), kept when it simulates the record better
        (``options["a_rule"]``, ``["a_source"]``).  None (default): the bandwidth pole,
        and the ``"dynamics"`` pass only when the first pass's modes are ill-conditioned
        at it (largest map-back amplification above
        :attr:`~hdpbsid.bases.laguerre_pole.PolePolicy.max_amplification`; a stiff
        record, whose slow modes the bandwidth pole maps next to ``-1``).
    N : int, optional
        Basis size (projection: the record fills 90 % of the support of ``N`` functions,
        ``N = 2 a T / 3.6`` clipped to ``[100, 4000]`` and to ``Ns / 2``, with a
        ``RuntimeWarning`` when an upper limit binds; filter: 30).
    variant : {"projection", "filter"}, optional
        ``"projection"``: the Laguerre coefficients of the windowed record, exact with the
        boundary pseudo-inputs; ``"filter"``: the outputs of the Laguerre filter network
        sampled at many times, an approximation valid once the initial transients decayed.
    n_times : int, optional
        Filter variant: sample times used after the burn-in (default 300).
    burn_in : float, optional
        Filter variant: seconds skipped (default ``min(T / 4, 10 / a)``).
    settings : BasisSettings, optional
        The shared settings (:class:`~hdpbsid.bases.settings.BasisSettings`).
    **shared
        The shared settings as keywords (``p``, ``f``, ``max_order``, ``boundary``,
        ``regularize``, ``stable_k``, ``normalize``, ``input_hold``, ``window``, ``n_jobs``;
        as in :func:`hdpbsid.methods.hermite.identify_hermite`).  ``feedthrough`` does not
        apply: the Laguerre-domain ``Dd`` is always estimated, and ``D`` is returned as
        identified.

    Returns
    -------
    StateSpaceModel
        The continuous-time model; ``K`` is mapped back like ``B`` and is approximate.

    Raises
    ------
    ValueError
        If ``variant`` is unknown, the filter variant gets several records, ``a`` is not a
        positive number, None, ``"bandwidth"`` or ``"dynamics"``, the data have no
        bandwidth to choose ``a`` from, or the burn-in leaves fewer than 2 samples.
    TypeError
        If an argument has the wrong type or a keyword is not a shared setting.

    Notes
    -----
    Laguerre functions of pole ``a`` have the Laplace transforms

    .. math:: L_n(s) = \sqrt{2a}\,\frac{(s - a)^n}{(s + a)^{n+1}},

    so the index shift is the all-pass :math:`w = (s - a)/(s + a)` and
    :math:`G(s) = D_d + C_d (zI - A_d)^{-1} B_d` with :math:`z = 1/w` (:func:`cayley`).

    References
    ----------
    .. [1] B. Wahlberg, "System identification using Laguerre models", *IEEE Trans.
       Automatic Control* 36(5), 551-562, 1991.
    .. [2] B. Ninness and F. Gustafsson, "A unifying construction of orthonormal bases for
       system identification", *IEEE Trans. Automatic Control* 42(4), 515-521, 1997.
    .. [3] Y. Ohta and T. Kawai, "Continuous-time subspace system identification using
       generalized orthonormal basis functions", *Int. J. Control* 77, 2004.
    .. [4] M. Bergamasco and M. Lovera, "Continuous-time predictor-based subspace
       identification using Laguerre filters", *IET Control Theory & Applications* 5(7),
       2011.

    Examples
    --------
    >>> from hdpbsid.systems.linear import second_order, simulate_zoh
    >>> A, B, C, D = second_order()  # eigenvalues -0.4 +- 1.9596j
    >>> t = np.arange(0.0, 40.0, 0.05)
    >>> u = (np.sin(0.7 * t) + np.sin(1.9 * t) + np.sin(3.1 * t))[:, None]
    >>> y = simulate_zoh(A, B, C, D, t, u)
    >>> model = identify_laguerre(t, u, y, order=2)
    >>> np.sort_complex(model.eigenvalues).round(4)
    array([-0.4-1.9596j, -0.4+1.9596j])
    >>> round(model.options["a"], 3)  # half the data bandwidth
    1.649
    """
    return fit_laguerre(
        Dataset.of(t, u, y), order, a=a, N=N, variant=variant, n_times=n_times,
        burn_in=burn_in, settings=settings, **shared,
    )  # fmt: skip


@library_call
def fit_laguerre(
    data: Dataset,
    order: int | None = None,
    *,
    a: float | str | None = None,
    N: int | None = None,
    variant: str = "projection",
    n_times: int | None = None,
    burn_in: float | None = None,
    settings: BasisSettings | None = None,
    **shared: Any,
) -> StateSpaceModel:
    """CT-PBSID on the records of ``data``: :func:`identify_laguerre` in the registry's
    call shape (:func:`hdpbsid.methods.registry.get_fit`).

    Parameters
    ----------
    data : Dataset
        The records, checked (one record is a Dataset of one).
    order : int, optional
        Model order (:func:`identify_laguerre`).
    a : float, "bandwidth", "dynamics" or None, optional
        The Laguerre pole (:func:`identify_laguerre`).
    N : int, optional
        Basis size.
    variant : {"projection", "filter"}, optional
        The coefficients' variant.
    n_times : int, optional
        Filter variant: sample times used after the burn-in.
    burn_in : float, optional
        Filter variant: seconds skipped.
    settings : BasisSettings, optional
        The shared settings.
    **shared
        The shared settings as keywords.

    Returns
    -------
    StateSpaceModel
        As :func:`identify_laguerre` returns it.
    """
    records = as_records(data)
    _check_variant(variant, records)
    # the shared ``feedthrough`` setting does not apply: the Laguerre-domain ``Dd`` is
    # always estimated (module docstring) and reported in options["feedthrough"]
    st = resolve_settings(settings, shared, "identify_laguerre")
    order = check_order(order)
    N = None if N is None else check_positive_int(N, "N", 2)
    wb = records_bandwidth(records)
    _check_pole_request(a, wb)
    asked = a if a is None or isinstance(a, str) else _real(a, "a")
    call = _Call(records, wb, variant, N, burn_in, n_times, st, order)
    pole, model = decide_pole(asked, 0.5 * wb, call.fit, records)
    model.options.update(pole.options())
    model.report = model.report.but(pole=Choice(pole.a, pole.reason, pole.rule))
    return model


identify_laguerre.sweep_settings = SWEEP_SETTINGS  # type: ignore[attr-defined]
identify_laguerre.fit = fit_laguerre  # type: ignore[attr-defined]


@dataclass(frozen=True)
class _Call:
    """The validated arguments of :func:`identify_laguerre` but the pole."""

    records: list[Record]
    wb: float
    variant: str
    N: int | None
    burn_in: float | None
    n_times: int | None
    st: BasisSettings
    order: int | None

    def fit(self, a: float) -> StateSpaceModel:
        """The model at the pole ``a`` (its ``a_rule`` is the pole decision's to write)."""
        records, wb, st = self.records, self.wb, self.st
        options: dict[str, Any] = {
            "method": "laguerre",
            "variant": self.variant,
            "a": a,
            "a_rule": "given",
            "bandwidth": wb,
            "feedthrough": "Laguerre-domain Dd estimated (required); D mapped back",
            "n_samples": int(sum(r.ns for r in records)),
            "t0": records[0].t0,
        }
        if self.variant == "filter":
            return _filter_variant(
                records[0], a, self.N, self.burn_in, self.n_times, st, self.order, options
            )
        fam = LaguerreFamily(a)
        q = fam.q[st.boundary]
        blocks = make_blocks(
            records,
            fam,
            st.window,
            lambda: default_window(records, fam.size_rate(wb), q, P_DEFAULT_RANGE[1]),
            size_policy(fam, self.N, wb),
        )
        proj = project(blocks, resolve_holds(st.input_hold, records[0].u.shape[1]), st.n_jobs)
        options.update({**blocks.options(), "boundary": st.boundary})
        return solve(proj, None, st, self.order, options).model


def _check_variant(variant: str, records: list[Record]) -> None:
    """``variant`` one of ``"projection"``, ``"filter"`` (the latter on one record)."""
    if variant not in ("projection", "filter"):
        raise ValueError(f"variant must be 'projection' or 'filter', got {variant!r}")
    if variant == "filter" and len(records) > 1:
        raise ValueError("variant='filter' takes one record; use variant='projection'")


def _check_pole_request(a: Any, wb: float) -> None:
    """A pole to be chosen (None, ``"dynamics"``) needs a data bandwidth ``wb > 0``; a
    string other than ``"dynamics"`` is no pole."""
    if (a is None or isinstance(a, str)) and wb <= 0:
        raise ValueError("cannot choose the Laguerre pole a: the data have no bandwidth")
    if isinstance(a, str) and a not in ("bandwidth", "dynamics"):
        raise ValueError(f"a must be a positive number, None, 'bandwidth' or 'dynamics', got {a!r}")


def _filter_variant(
    rec: Record,
    a: float,
    N: int | None,
    burn_in: float | None,
    n_times: int | None,
    st: BasisSettings,
    order: int | None,
    options: dict[str, Any],
) -> StateSpaceModel:
    """The filter variant (module docstring): Laguerre filter outputs at ``n_times`` times
    after ``burn_in`` seconds, blocks of ``N`` reversed Laguerre indices per time."""
    t, u, y = rec.t, rec.u, rec.y
    m = u.shape[1]
    N = 30 if N is None else N
    burn = min(rec.duration / 4, 10.0 / a) if burn_in is None else _real(burn_in, "burn_in", False)
    nt = 300 if n_times is None else check_positive_int(n_times, "n_times")
    idx = np.flatnonzero(t >= t[0] + burn)
    if idx.size < 2:
        raise ValueError(f"burn_in={burn} leaves fewer than 2 samples of the record")
    idx = idx[np.unique(np.linspace(0, idx.size - 1, min(nt, idx.size)).astype(int))]
    fu = laguerre_filter(t, u, a, N)[idx] if m else np.zeros((idx.size, 0, N))
    fy = laguerre_filter(t, y, a, N)[idx]
    # columns: block per time, reversed Laguerre index inside the block
    Us = [fu[:, :, ::-1].transpose(1, 0, 2).reshape(m, -1)]
    Yc = fy[:, :, ::-1].transpose(1, 0, 2).reshape(y.shape[1], -1)
    lag = BlockLag([BlockShift(N)], [Yc.shape[1]])
    core_options = {**st.core_options(order), "feedthrough": True}
    out, _, _ = best_hold(("foh",), Us, Yc, None, lag, **core_options)
    info = {"N": N, "burn_in": burn, "n_times": int(idx.size)}
    return laguerre_model(out, a, {**info, **options}, st, order)
