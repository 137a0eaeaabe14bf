"""Identified models: continuous-time :class:`StateSpaceModel` and sampled :class:`DiscreteModel`.

Both hold the innovation form ``x' = A x + B u + K e``, ``y = C x + D u + e`` (``x'`` is
``dx/dt`` or ``x_{k+1}``), the singular values the order was chosen from and the
``options`` actually used.  Simulation, prediction, fit statistics, frequency responses
and conversions to scipy / python-control are their methods; identification lives
elsewhere.  The parts are siblings of this module, and every name is importable from
here: the common fields (:mod:`~hdpbsid.models.model_base`, with :class:`LinearTrend`),
:class:`FitResult` (:mod:`~hdpbsid.models.fit_result`), the time-scale check
(:mod:`~hdpbsid.models.time_scale`), the sampled system over a record's steps
(:mod:`~hdpbsid.models.simulation`), the forms of scipy and python-control
(:mod:`~hdpbsid.models.interop`) and :func:`scale_signals`
(:mod:`~hdpbsid.models.scaling`).

**Operating point.**  The matrices describe *deviations* from an operating point
``(u0, y0)``: with absolute signals ``u``, ``y`` the model is

    x' = A x + B (u - u0) + K e,    y = y0 + C x + D (u - u0) + e,

(Ljung, *System Identification*, 2nd ed., sec. 14.1: identify on signals with their
levels removed, put the levels back when the model is used).  ``u0`` and ``y0`` default
to zero (a model built by hand is exactly the matrices); :func:`hdpbsid.identify` stores
the levels it removed.  With a linear trend (``detrend="linear"``) the operating point
is ``u0 + u_slope (t - t_ref)`` and ``y0 + y_slope (t - t_ref)`` (:class:`LinearTrend`).
:meth:`StateSpaceModel.simulate`, :meth:`~StateSpaceModel.fit`,
:meth:`~StateSpaceModel.predict` and :meth:`~StateSpaceModel.compare` take and return
absolute signals; states ``x`` (and ``x0``) are always deviation states.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hdpbsid.data.checks import (
    as_float_array,
    check_positive_int,
    check_signal,
    check_time,
    is_uniform,
)
from hdpbsid.models.assessment import Comparison, ResidualReport, fit_percent, residual_tests
from hdpbsid.models.conversion import c2d, d2c
from hdpbsid.models.dead_time import check_delay, pade_order
from hdpbsid.models.fit_result import FitResult, fit_statistics
from hdpbsid.models.interop import (
    control_labels,
    import_control,
    innovation_names,
    transfer,
    with_pade,
)
from hdpbsid.models.model_base import LinearTrend, _ModelBase
from hdpbsid.models.model_base import _set_levels as _set_levels
from hdpbsid.models.recursion import linear_recursion
from hdpbsid.models.scaling import scale_signals
from hdpbsid.models.simulation import (
    check_input,
    check_output,
    check_x0,
    forced_and_free,
    initial_state,
    input_steps,
    input_terms,
    output_weights,
    step_groups,
    step_matrices,
)
from hdpbsid.models.time_scale import (
    SAMPLING_RATIO_LIMIT,
    TIME_UNITS,
    TimeScaleWarning,
    check_interval,
    check_time_scale,
)
from hdpbsid.models.uncertainty import ParameterCovariance
from hdpbsid.runtime import library_call

__all__ = [
    "StateSpaceModel",
    "DiscreteModel",
    "FitResult",
    "LinearTrend",
    "fit_statistics",
    "TimeScaleWarning",
    "TIME_UNITS",
    "SAMPLING_RATIO_LIMIT",
    "scale_signals",
]

Array = NDArray[np.float64]


@dataclass(repr=False)
class StateSpaceModel(_ModelBase):
    """Continuous-time innovation model ``dx/dt = A x + B u + K e``, ``y = C x + D u + e``.

    The matrices describe deviations from the operating point ``(u0, y0)`` (module
    docstring); :meth:`simulate`, :meth:`fit`, :meth:`predict` and :meth:`compare` take and
    return absolute signals.

    Parameters
    ----------
    A : array_like, shape (n, n)
        State matrix (rad per ``time_unit``: its eigenvalues are the poles).
    B : array_like, shape (n, m)
        Input matrix.
    C : array_like, shape (l, n)
        Output matrix.
    D : array_like, shape (l, m)
        Direct feedthrough.
    K : array_like, shape (n, l)
        Innovation gain, in the hold convention of :mod:`hdpbsid.models.conversion`.
    singular_values : ndarray or None, optional
        The singular values of the SVD step the order was chosen from.
    options : dict, optional
        Every setting the identification used, defaults included: a record for printing
        and the model file (the stages of the identification read ``report``).
    noise_covariance : ndarray, shape (l, l), or None, optional
        Innovation covariance estimate; ``None`` when unknown.
    u0, y0 : array_like, shape (m,) and (l,), optional
        Operating point (default zeros: a model built by hand is exactly its matrices).
    trend : LinearTrend or None, optional
        Linear drift of the operating point (``detrend="linear"``).
    time_unit : str, optional
        Unit of the times ``t`` (default ``"s"``); the eigenvalues are in rad per that unit.
    input_names, output_names : list of str, optional
        Channel names (default ``u1, ...`` and ``y1, ...``).
    report : IdentificationReport or None, optional (keyword only)
        What the identification decided and why (:mod:`hdpbsid.models.report`); without
        one, ``model.report`` is the report of ``options``
        (:meth:`IdentificationReport.from_options`).
    discrete : DiscreteModel or None, optional
        The sampled model this one was converted from, if any.
    sampling_interval : float or None, optional
        Median step of the identification record in ``time_unit``; :meth:`check_record`
        compares a record with it.
    delay : float or array_like, shape (m,), optional
        Dead time of each input, ``>= 0`` in ``time_unit`` (a scalar is used for every
        input): ``dx/dt = A x + B u(t - delay) + K e``, ``y = C x + D u(t - delay) + e``
        (:mod:`hdpbsid.models.dead_time`).  The matrices are the delay-free part.
    parameter_covariance : ParameterCovariance or None, optional
        Covariance of ``[vec A, vec B, vec C, vec D]`` from the fit (set by
        ``refine="pem"`` and :func:`hdpbsid.frequency.fit.identify_frequency`), which
        :func:`hdpbsid.models.uncertainty.response_band` turns into a band of the frequency
        response.

    Attributes
    ----------
    n, m, l : int
        State, input and output dimensions.
    eigenvalues : ndarray of complex
        Eigenvalues of ``A`` sorted by real, then imaginary part.
    has_delay : bool
        Whether any input has a dead time.

    Raises
    ------
    ValueError
        If the matrices' shapes disagree, an entry is not finite, a name list has the wrong
        length or repeats a name, ``sampling_interval`` is not positive or a delay is
        negative.
    TypeError
        If a label is not a string or ``parameter_covariance`` has the wrong type.

    Notes
    -----
    Dead times are honoured exactly by :meth:`simulate`, :meth:`fit`, :meth:`predict` and
    :meth:`frequency_response`; :meth:`to_control` and :meth:`to_scipy` replace them by a
    Pade approximant (:meth:`pade_order`); :meth:`to_discrete` refuses a delayed model
    (its exact sampled model needs extra states).

    Examples
    --------
    A first-order low-pass ``G(s) = 1 / (s + 1)``:

    >>> import numpy as np
    >>> from hdpbsid import StateSpaceModel
    >>> model = StateSpaceModel(A=[[-1.0]], B=[[1.0]], C=[[1.0]], D=[[0.0]], K=[[0.5]])
    >>> model
    StateSpaceModel(continuous, n=1, m=1, l=1, eigenvalues=[-1])
    >>> t = np.arange(0.0, 20.0, 0.01)
    >>> y = model.simulate(t, np.ones((t.size, 1)))
    >>> round(float(y[-1, 0]), 4)  # the step response settles at the DC gain G(0) = 1
    1.0
    >>> np.round(model.frequency_response([0.0, 1.0])[0, 0], 3)  # G(0), G(j) = 1 / (1 + j)
    array([1. +0.j , 0.5-0.5j])
    """

    discrete: DiscreteModel | None = None
    sampling_interval: float | None = None
    delay: Array | None = None
    parameter_covariance: ParameterCovariance | None = None

    def __post_init__(self) -> None:
        super().__post_init__()
        self.sampling_interval = check_interval(self.sampling_interval, "sampling_interval")
        self.delay = check_delay(self.delay, self.m)
        cov = self.parameter_covariance
        if cov is not None:
            if not isinstance(cov, ParameterCovariance):
                raise TypeError(
                    "parameter_covariance must be a hdpbsid.models.uncertainty.ParameterCovariance "
                    f"or None, got {type(cov).__name__}"
                )
            cov.check(self.n, self.m, self.l)

    @property
    def has_delay(self) -> bool:
        """Whether any input has a dead time."""
        return bool(np.any(self.delay))

    def save(self, path: Any) -> Any:
        """Write the model to a JSON file.

        Parameters
        ----------
        path : str or path-like
            File to write (:func:`hdpbsid.models.model_io.save_model`); :func:`hdpbsid.load_model`
            reads it back with every label, the operating point and the dead times.

        Returns
        -------
        pathlib.Path
            The path written.

        Raises
        ------
        ValueError
            If the path's suffix is not ``.json`` (:func:`~hdpbsid.models.model_file.write_model`).

        Examples
        --------
        >>> import tempfile, pathlib
        >>> from hdpbsid import StateSpaceModel, load_model
        >>> model = StateSpaceModel(A=[[-2.0]], B=[[1.0]], C=[[3.0]], D=[[0.0]], K=[[0.0]])
        >>> with tempfile.TemporaryDirectory() as tmp:
        ...     path = model.save(pathlib.Path(tmp) / "model.json")
        ...     back = load_model(path)
        >>> back.eigenvalues.real.tolist(), back.C.tolist()
        ([-2.0], [[3.0]])
        """
        from hdpbsid.models.model_file import write_model

        return write_model(self, path)

    def check_record(self, t: Any, time_unit: str | None = None, name: str = "t") -> None:
        """Warn when a record's time scale does not match the model's.

        Two checks, each only when both sides are known: ``time_unit`` (the record's)
        differs from ``model.time_unit`` (the message gives the conversion factor for the
        units of :data:`TIME_UNITS`); the record's median step differs from
        ``model.sampling_interval`` by more than :data:`SAMPLING_RATIO_LIMIT` either way, the
        signature of times in another unit (its comment says why that factor).

        Parameters
        ----------
        t : array_like, shape (Ns,)
            The record's sample times.
        time_unit : str or None, optional
            The unit of ``t``, if known.
        name : str, optional
            The argument's name in the messages.

        Warns
        -----
        TimeScaleWarning
            When either check fails.

        Raises
        ------
        ValueError
            If ``t`` is not a strictly increasing finite vector, or ``time_unit`` is empty.

        Notes
        -----
        The exact sampled model simulates any step size, so neither finding is an error: the
        fit of a record in the wrong unit is merely meaningless.
        """
        check_time_scale(t, time_unit, self.time_unit, self.sampling_interval, name)

    def __repr__(self) -> str:
        method = self.report.method if self.report is not None else None
        extra = f", method={method!r}" if method else ""
        if self.has_delay:
            extra += f", delay={np.array2string(self.delay, precision=6)} {self.time_unit}"
        return f"StateSpaceModel(continuous, {self._repr_body()}{extra})"

    # -- simulation ------------------------------------------------------------------
    @library_call
    def simulate(
        self,
        t: Any,
        u: Any,
        x0: Any | None = None,
        method: str = "zoh",
        return_states: bool = False,
    ) -> Array | tuple[Array, Array]:
        r"""Deterministic response (``e = 0``) at the times ``t``, which need not be uniform.

        Parameters
        ----------
        t : array_like, shape (Ns,)
            Strictly increasing sample times in ``time_unit``.
        u : array_like, shape (Ns, m) or (Ns,)
            Absolute input: the model runs on ``u - u0`` and adds ``y0`` to its output.
            ``None`` is accepted for a model without inputs.
        x0 : array_like, shape (n,), optional
            Initial *deviation* state (default 0: the system at its operating point).
        method : {"zoh", "foh"}, optional
            ``"zoh"``: ``u[k]`` held on ``[t_k, t_{k+1})`` (the assumption under which
            :func:`~hdpbsid.identify_dt` data are sampled); ``"foh"``: ``u`` linear between
            samples, as :func:`scipy.signal.lsim` does by default.
        return_states : bool, optional
            Also return the deviation states.

        Returns
        -------
        y : ndarray, shape (Ns, l)
            The absolute output.
        x : ndarray, shape (Ns, n)
            The deviation states (only with ``return_states``).

        Raises
        ------
        ValueError
            If ``method`` is unknown, ``t`` is not strictly increasing, ``u`` has the wrong
            shape or ``x0`` the wrong length.

        Notes
        -----
        Each step uses the exact exponential of the augmented matrix for its own
        ``h = t_{k+1} - t_k`` (Franklin, Powell & Workman, *Digital Control of Dynamic
        Systems*, sec. 6.3),

        .. math::

            \exp\begin{bmatrix} A h & B h & 0 \\ 0 & 0 & I \\ 0 & 0 & 0 \end{bmatrix}
            = \begin{bmatrix} \Phi & \Gamma_1 & \Gamma_2 \\ 0 & I & I \\ 0 & 0 & I
            \end{bmatrix},
            \qquad x_{k+1} = \Phi x_k + \Gamma_1 u_k + \Gamma_2 (u_{k+1} - u_k),

        with the last term only for the first-order hold; steps equal to 1e-12 relative share
        one exponential, so a uniform record needs one.

        Examples
        --------
        >>> import numpy as np
        >>> from hdpbsid import StateSpaceModel
        >>> model = StateSpaceModel(A=[[-1.0]], B=[[1.0]], C=[[1.0]], D=[[0.0]], K=[[0.0]])
        >>> t = np.array([0.0, 0.5, 1.0, 3.0])  # non-uniform steps are exact too
        >>> y = model.simulate(t, np.ones(4))
        >>> np.allclose(y[:, 0], 1.0 - np.exp(-t))  # the step response 1 - e^{-t}
        True
        """
        t, u = check_input(self, t, u, method)
        U0, Y0 = self.operating_point(t)
        y, X = self._simulate_deviation(t, u - U0, check_x0(self, x0), method)
        y = y + Y0
        return (y, X) if return_states else y

    def _simulate_deviation(self, t: Array, u: Array, x: Array, method: str) -> tuple[Array, Array]:
        """Response ``(y, X)`` of the matrices alone to the deviation input ``u``."""
        ns, n = t.shape[0], self.n
        X = np.empty((ns, n))
        X[0] = x
        ud = u
        if ns > 1:
            Phi, inv, Bu, ud = input_steps(self, t, u, method)
            if Phi.shape[0] == 1:  # uniform sampling: modal filters
                X = linear_recursion(Phi[0], Bu, x)
            else:
                for k in range(ns - 1):
                    x = Phi[inv[k]] @ x + Bu[k]
                    X[k + 1] = x
        elif self.has_delay:
            ud = np.where(self.delay[None, :] > 0, 0.0, u)
        return X @ self.C.T + ud @ self.D.T, X

    @library_call
    def fit(
        self,
        t: Any,
        u: Any,
        y: Any,
        x0: Any = "estimate",
        method: str = "zoh",
        time_unit: str | None = None,
    ) -> FitResult:
        """Simulate on ``(t, u)`` and compare with ``y``: VAF and NRMSE per output.

        Parameters
        ----------
        t : array_like, shape (Ns,)
            Strictly increasing sample times in ``time_unit``.
        u : array_like, shape (Ns, m)
            Absolute input.
        y : array_like, shape (Ns, l)
            Absolute measured output.
        x0 : {"estimate", "zero"} or array_like, shape (n,), optional
            ``"estimate"`` (default) fits the initial deviation state by least squares (the
            output is affine in ``x0``), each output divided by its spread
            (:func:`~hdpbsid.models.simulation.output_weights`: the same state in any
            units); ``"zero"`` or an array use that state.
        method : {"zoh", "foh"}, optional
            Input between samples, as in :meth:`simulate`.
        time_unit : str or None, optional
            The unit of ``t``, if known; a record whose time scale does not match the model's
            draws a :class:`TimeScaleWarning` (:meth:`check_record`).

        Returns
        -------
        FitResult
            ``vaf``, ``nrmse``, ``fit`` per output, the simulated output and the initial state.

        Raises
        ------
        ValueError
            If ``x0`` is an unknown string or has the wrong length, or the signals' shapes
            disagree with the model's.

        Examples
        --------
        >>> import numpy as np
        >>> from hdpbsid import StateSpaceModel
        >>> model = StateSpaceModel(A=[[-1.0]], B=[[1.0]], C=[[1.0]], D=[[0.0]], K=[[0.0]])
        >>> rng = np.random.default_rng(0)
        >>> t = np.arange(0.0, 20.0, 0.01)
        >>> u = np.repeat(rng.standard_normal(20), 100)[:, None]  # steps held for 1 s
        >>> y = model.simulate(t, u, x0=[2.0])  # started away from rest
        >>> result = model.fit(t, u, y)
        >>> print(np.round(result.fit, 6), np.round(result.x0, 6))  # x0 recovered by least squares
        [100.] [2.]
        """
        self.check_record(t, time_unit)
        return self._fit(t, u, y, x0, method)

    def _fit(
        self, t: Any, u: Any, y: Any, x0: Any, method: str, weights: Array | None = None
    ) -> FitResult:
        """:meth:`fit` with the initial state fitted under the output ``weights``, default
        :func:`~hdpbsid.models.simulation.output_weights` of ``y`` (the held-out window
        scorer of :mod:`hdpbsid.models.criteria` passes ones: the reason there)."""
        t = check_time(t, "t")
        y = check_output(self, t, y)
        t, u = check_input(self, t, u, method)
        U0, Y0 = self.operating_point(t)
        ud = u - U0
        if isinstance(x0, str):
            if x0 not in ("estimate", "zero"):
                raise ValueError(f"x0 must be 'estimate', 'zero' or an array, got {x0!r}")
            x0v = np.zeros(self.n)
            w = output_weights(y) if weights is None else weights
            if x0 == "estimate" and self.n > 0 and not is_uniform(t):
                # non-uniform steps: one pass for the forced and all free responses
                y_sim, O = forced_and_free(self, t, ud, method)
                x0v = initial_state(O, (y - Y0 - y_sim).ravel(), w)
                y_sim = y_sim + Y0 + (O @ x0v).reshape(y.shape)
                vaf, nrmse = fit_statistics(y, y_sim)
                return FitResult(vaf=vaf, nrmse=nrmse, y_sim=y_sim, x0=x0v)
            y_sim = self._simulate_deviation(t, ud, x0v, method)[0] + Y0
            if x0 == "estimate" and self.n > 0:
                ufree = np.zeros((t.shape[0], self.m))
                O = np.stack(
                    [
                        self._simulate_deviation(t, ufree, e, method)[0].ravel()
                        for e in np.eye(self.n)
                    ],
                    axis=1,
                )
                x0v = initial_state(O, (y - y_sim).ravel(), w)
                y_sim = y_sim + (O @ x0v).reshape(y.shape)
        else:
            x0v = check_x0(self, x0)
            y_sim = self._simulate_deviation(t, ud, x0v, method)[0] + Y0
        vaf, nrmse = fit_statistics(y, y_sim)
        return FitResult(vaf=vaf, nrmse=nrmse, y_sim=y_sim, x0=x0v)

    # -- prediction and validation -----------------------------------------------------
    def _predict_deviation(
        self, t: Array, u: Array, y: Array, x: Array, k: int, method: str
    ) -> Array:
        """k-step-ahead predictions of the deviation output (module docstring of
        :meth:`predict`), for deviation signals ``u``, ``y`` and initial state ``x``."""
        ns, n = t.shape[0], self.n
        Z = np.empty((ns, n))
        Z[0] = x
        if ns > 1:
            _, hg, inv = step_groups(t)
            Phi, G1, G2, Gk = step_matrices(self, hg, method, with_k=True)
            Bu, u = input_terms(self, t, u, method, Phi, G1, G2, inv)  # u: the delayed input
            Ku = np.einsum("kij,kj->ki", Gk[inv], y[:-1] - u[:-1] @ self.D.T)
            # predictor: x_{j+1} = (Phi - Gk C) x_j + Bu_j + Gk (y_j - D u_j)
            F = Phi - np.einsum("kij,jl->kil", Gk, self.C)
            if F.shape[0] == 1:  # uniform sampling: one predictor matrix, modal filters
                Z = linear_recursion(F[0], Bu + Ku, x)
            else:
                for j in range(ns - 1):
                    x = F[inv[j]] @ x + Bu[j] + Ku[j]
                    Z[j + 1] = x
            # Z[j] = x_{j|j-1}; k - 1 open-loop steps give x_{j|j-k} (x_{j|.} = x0 for the
            # first samples, where no measurement precedes)
            for _ in range(k - 1):
                Znew = np.empty_like(Z)
                Znew[0] = Z[0]
                Znew[1:] = np.einsum("kij,kj->ki", Phi[inv], Z[:-1]) + Bu
                Z = Znew
        return Z @ self.C.T + u @ self.D.T

    def _predict(
        self, t: Any, u: Any, y: Any, k: int, x0: Any, method: str
    ) -> tuple[Array, Array, Array]:
        k = check_positive_int(k, "k")
        t = check_time(t, "t")
        y = check_output(self, t, y)
        t, u = check_input(self, t, u, method)
        U0, Y0 = self.operating_point(t)
        ud, yd = u - U0, y - Y0
        if isinstance(x0, str):
            if x0 not in ("estimate", "zero"):
                raise ValueError(f"x0 must be 'estimate', 'zero' or an array, got {x0!r}")
            x0v = np.zeros(self.n)
            yp = self._predict_deviation(t, ud, yd, x0v, k, method)
            if x0 == "estimate" and self.n > 0:
                zu, zy = np.zeros_like(ud), np.zeros_like(yd)
                O = np.stack(
                    [
                        self._predict_deviation(t, zu, zy, e, k, method).ravel()
                        for e in np.eye(self.n)
                    ],
                    axis=1,
                )
                x0v = initial_state(O, (yd - yp).ravel(), output_weights(yd))
                yp = yp + (O @ x0v).reshape(yd.shape)
        else:
            x0v = check_x0(self, x0)
            yp = self._predict_deviation(t, ud, yd, x0v, k, method)
        return yp + Y0, x0v, y

    @library_call
    def predict(
        self,
        t: Any,
        u: Any,
        y: Any,
        k: int = 1,
        x0: Any = "estimate",
        method: str = "zoh",
        time_unit: str | None = None,
    ) -> Array:
        r"""``k``-step-ahead predictions ``y_hat(t_j | t_{j-k})`` of the measured ``y``.

        Parameters
        ----------
        t : array_like, shape (Ns,)
            Strictly increasing sample times (need not be uniform).
        u : array_like, shape (Ns, m)
            Absolute input.
        y : array_like, shape (Ns, l)
            Absolute measured output.
        k : int, optional
            Prediction horizon in samples, ``>= 1``.  ``k = 1`` is the one-step predictor whose
            errors are the model's innovations; a large ``k`` approaches :meth:`simulate`.
        x0 : {"estimate", "zero"} or array_like, shape (n,), optional
            ``"estimate"`` (least squares on the prediction errors, in which the predictions
            are affine; each output divided by its spread, as in :meth:`fit`), ``"zero"``
            or the initial deviation state.
        method : {"zoh", "foh"}, optional
            Input between samples.
        time_unit : str or None, optional
            As in :meth:`fit`.

        Returns
        -------
        ndarray, shape (Ns, l)
            The predicted absolute output.

        Raises
        ------
        ValueError
            If ``k`` is not a positive integer, ``x0`` an unknown string, or the signals' shapes
            disagree with the model's.
        TypeError
            If ``k`` is not an integer.

        Notes
        -----
        The sampled innovation model (hold convention of :mod:`hdpbsid.models.conversion`:
        ``u`` and ``e`` held over each step, exact exponentials per step) gives the one-step
        predictor (Ljung, *System Identification*, 2nd ed., 1999, eq. 4.87)

        .. math::

            \hat x_{j+1|j} = \Phi_j \hat x_{j|j-1} + \Gamma_j u_j
            + G_j \bigl(y_j - C \hat x_{j|j-1} - D u_j\bigr),

        and :math:`\hat x_{j|j-k}` follows from :math:`\hat x_{j-k+1|j-k}` by ``k - 1`` steps
        of the model without the correction term; :math:`\hat y = C \hat x_{j|j-k} + D u_j`.

        Examples
        --------
        >>> import numpy as np
        >>> from hdpbsid import StateSpaceModel
        >>> model = StateSpaceModel(A=[[-1.0]], B=[[1.0]], C=[[1.0]], D=[[0.0]], K=[[2.0]])
        >>> rng = np.random.default_rng(1)
        >>> t = np.arange(0.0, 10.0, 0.05)
        >>> u = np.repeat(rng.standard_normal(10), 20)[:, None]
        >>> y = model.simulate(t, u) + 0.1 * rng.standard_normal((t.size, 1))
        >>> y1 = model.predict(t, u, y, k=1)
        >>> y1.shape
        (200, 1)
        """
        self.check_record(t, time_unit)
        return self._predict(t, u, y, k, x0, method)[0]

    @library_call
    def compare(
        self,
        t: Any,
        u: Any,
        y: Any,
        k: int | None = None,
        method: str = "zoh",
        time_unit: str | None = None,
    ) -> Comparison:
        r"""Fit of the model on a record, as MATLAB's ``compare``.

        Per output, :math:`\mathrm{fit} = 100\,(1 - \|y - \hat y\| / \|y - \bar y\|)`
        percent.

        Parameters
        ----------
        t : array_like, shape (Ns,)
            Strictly increasing sample times.
        u : array_like, shape (Ns, m)
            Absolute input.
        y : array_like, shape (Ns, l)
            Absolute measured output.
        k : int or None, optional
            ``None``: ``y_hat`` is the simulation (:meth:`fit`, initial state by least
            squares), which diverges for an unstable model; an integer: the ``k``-step-ahead
            prediction (:meth:`predict`, initial state by least squares).
        method : {"zoh", "foh"}, optional
            Input between samples.
        time_unit : str or None, optional
            The unit of ``t``, if known (:meth:`check_record`).

        Returns
        -------
        Comparison
            ``fit`` per output, ``y_hat``, the initial state and ``k``
            (:class:`~hdpbsid.models.assessment.Comparison`).

        Raises
        ------
        ValueError
            If ``k`` is not a positive integer or the signals' shapes disagree with the model's.

        Examples
        --------
        >>> import numpy as np
        >>> from hdpbsid import StateSpaceModel
        >>> model = StateSpaceModel(A=[[-1.0]], B=[[1.0]], C=[[1.0]], D=[[0.0]], K=[[0.5]])
        >>> rng = np.random.default_rng(0)
        >>> t = np.arange(0.0, 20.0, 0.01)
        >>> u = np.repeat(rng.standard_normal(20), 100)[:, None]
        >>> y = model.simulate(t, u) + 0.05 * rng.standard_normal((t.size, 1))
        >>> bool(model.compare(t, u, y).fit[0] > 85)  # the noise caps the fit below 100 %
        True
        """
        self.check_record(t, time_unit)
        if k is None:
            res = self._fit(t, u, y, "estimate", method)
            y_meas = check_signal(y, "y", limit_energy=False)
            return Comparison(
                fit=fit_percent(y_meas, res.y_sim), y_hat=res.y_sim, x0=res.x0, k=None
            )
        y_hat, x0v, y_meas = self._predict(t, u, y, k, "estimate", method)
        return Comparison(fit=fit_percent(y_meas, y_hat), y_hat=y_hat, x0=x0v, k=int(k))

    @library_call
    def residuals(
        self,
        t: Any,
        u: Any,
        y: Any,
        max_lag: int = 25,
        method: str = "zoh",
        time_unit: str | None = None,
    ) -> ResidualReport:
        """Residual analysis of the one-step prediction errors, as MATLAB's ``resid``.

        The errors ``e = y - y_hat(t | t - 1)`` (:meth:`predict` with ``k=1``, initial state
        by least squares) are tested for whiteness (autocorrelation, Ljung-Box) and for
        independence from the input (cross-correlation) over lags up to ``max_lag``
        (Ljung, *System Identification*, 2nd ed., 1999, sec. 16.6;
        :func:`hdpbsid.models.assessment.residual_tests`).

        Parameters
        ----------
        t : array_like, shape (Ns,)
            Strictly increasing sample times.
        u : array_like, shape (Ns, m)
            Absolute input.
        y : array_like, shape (Ns, l)
            Absolute measured output.
        max_lag : int, optional
            Largest lag ``M`` tested (at most ``Ns - 1``).
        method : {"zoh", "foh"}, optional
            Input between samples.
        time_unit : str or None, optional
            As in :meth:`compare`.

        Returns
        -------
        ResidualReport
            The correlations, their bands and the tests' statistics
            (:class:`~hdpbsid.models.assessment.ResidualReport`).

        Raises
        ------
        ValueError
            If ``max_lag`` is not a positive integer below ``Ns`` or the shapes disagree.

        Examples
        --------
        >>> import numpy as np
        >>> from hdpbsid import StateSpaceModel
        >>> model = StateSpaceModel(A=[[-1.0]], B=[[1.0]], C=[[1.0]], D=[[0.0]], K=[[0.0]])
        >>> rng = np.random.default_rng(0)
        >>> t = np.arange(0.0, 20.0, 0.01)
        >>> u = np.repeat(rng.standard_normal(20), 100)[:, None]
        >>> y = model.simulate(t, u) + 0.05 * rng.standard_normal((t.size, 1))
        >>> report = model.residuals(t, u, y)  # output error: white noise, the right model
        >>> report.white, report.independent
        (True, True)
        """
        self.check_record(t, time_unit)
        y_hat, _, y_meas = self._predict(t, u, y, 1, "estimate", method)
        t_arr = check_time(t, "t")
        _, u_arr = check_input(self, t_arr, u, method)
        return residual_tests(y_meas - y_hat, u_arr, max_lag=max_lag)

    # -- frequency domain and conversions -----------------------------------------------
    def frequency_response(self, w: Any) -> NDArray[np.complex128]:
        r"""Frequency response with the dead times entering exactly.

        Parameters
        ----------
        w : array_like, shape (nw,)
            Angular frequencies in rad per ``time_unit``.

        Returns
        -------
        ndarray of complex, shape (l, m, nw)
            :math:`G(j\omega) = \bigl(C (j\omega I - A)^{-1} B + D\bigr)
            \operatorname{diag}(e^{-j\omega \tau_i})`, in python-control's layout.

        Raises
        ------
        ValueError
            If ``w`` is not finite.

        Examples
        --------
        >>> import numpy as np
        >>> from hdpbsid import StateSpaceModel
        >>> model = StateSpaceModel(A=[[-1.0]], B=[[1.0]], C=[[1.0]], D=[[0.0]], K=[[0.0]],
        ...                         delay=0.1)
        >>> G = model.frequency_response([1.0])[0, 0, 0]
        >>> round(float(abs(G)), 4), round(float(np.angle(G)), 4)  # |1/(1+j)|, -pi/4 - 0.1
        (0.7071, -0.8854)
        """
        w = as_float_array(w, "w").reshape(-1)
        s = 1j * w
        G = transfer(self.A, self.B, self.C, self.D, s)
        if self.has_delay:
            G = G * np.exp(-1j * self.delay[None, :, None] * w[None, None, :])
        return G

    def pade_order(self, w_max: float | None = None) -> int:
        """Order of the Pade approximant :meth:`to_control` and :meth:`to_scipy` use by default.

        Parameters
        ----------
        w_max : float or None, optional
            Highest angular frequency (rad per ``time_unit``) at which the approximant's phase
            must be within 1 degree of every dead time's.  Default: a decade above the fastest
            eigenvalue (``10 max |lambda|``, where a strictly proper model's gain has fallen by
            20 dB or more from that mode's), or the Nyquist frequency
            ``pi / sampling_interval`` when that is lower (the data say nothing above it).

        Returns
        -------
        int
            The smallest such order (:func:`hdpbsid.models.dead_time.pade_order`, at most
            :data:`hdpbsid.models.dead_time.MAX_PADE_ORDER`); 0 for a model without delay.
        """
        if not self.has_delay:
            return 0
        if w_max is None:
            top = [10.0 * float(np.max(np.abs(self.eigenvalues), initial=0.0))]
            if self.sampling_interval is not None:
                top.append(np.pi / self.sampling_interval)
            positive = [x for x in top if x > 0]
            w_max = min(positive) if positive else 1.0 / float(np.max(self.delay))
        return pade_order(self.delay, float(w_max))

    def to_discrete(self, dt: float) -> DiscreteModel:
        """Zero-order-hold sampling of the model.

        Parameters
        ----------
        dt : float
            Sampling interval in ``time_unit``, positive.

        Returns
        -------
        DiscreteModel
            ``(Ad, Bd, C, D, Kd)`` of :func:`hdpbsid.models.conversion.c2d` (``K`` by the hold
            convention), with the operating point and the labels.

        Raises
        ------
        ValueError
            For a model with a dead time (its exact sampled model needs states for the delayed
            inputs, which :class:`DiscreteModel` does not hold: sample ``model.to_control()``,
            the Pade approximant, or simulate the continuous model), or a ``dt`` that is not
            positive.

        Examples
        --------
        >>> import numpy as np
        >>> from hdpbsid import StateSpaceModel
        >>> model = StateSpaceModel(A=[[-1.0]], B=[[1.0]], C=[[1.0]], D=[[0.0]], K=[[0.0]])
        >>> sampled = model.to_discrete(0.1)
        >>> bool(np.isclose(sampled.A[0, 0], np.exp(-0.1)))  # Ad = e^{A dt}
        True
        >>> bool(np.allclose(sampled.to_continuous().A, model.A))  # d2c inverts c2d
        True
        """
        if self.has_delay:
            raise ValueError(
                f"to_discrete: the model has dead times {self.delay.tolist()} "
                f"{self.time_unit}; the exact sampled model of a delay needs extra states. "
                f"Simulate the continuous model (exact), or sample its Pade approximant "
                f"(control.sample_system(model.to_control(), dt))"
            )
        Ad, Bd, C, D, Kd = c2d(self.A, self.B, self.C, self.D, self.K, dt)
        return DiscreteModel(
            Ad,
            Bd,
            C,
            D,
            Kd,
            dt=float(dt),
            options={"from": "c2d (zoh)"},
            **self._offsets_kwargs(),
        )

    def to_scipy(self, pade_order: int | None = None) -> Any:
        """The model as ``scipy.signal.StateSpace(A, B, C, D)`` (continuous; the ``u -> y`` part).

        It describes *deviations* from the operating point: feed it ``u - model.u0`` and add
        ``model.y0`` to its output (module docstring); scipy has no place for levels.

        Parameters
        ----------
        pade_order : int or None, optional
            Order of the Pade approximants that replace the dead times on the inputs (their
            states after the model's); default :meth:`pade_order`.

        Returns
        -------
        scipy.signal.StateSpace
            The continuous system.
        """
        from scipy.signal import StateSpace

        return StateSpace(*with_pade(self, pade_order))

    def to_control(
        self, noise_inputs: bool = False, name: str | None = None, pade_order: int | None = None
    ) -> Any:
        """The model as a continuous ``control.StateSpace`` with named signals.

        The signals are named after ``input_names`` and ``output_names``.  Like :meth:`to_scipy`
        it describes deviations (inputs ``u - model.u0``, outputs ``y - model.y0``) and time in
        ``model.time_unit``: python-control has neither operating point nor unit.

        Parameters
        ----------
        noise_inputs : bool, optional
            With it the inputs are ``[u, e]`` (``B -> [B, K]``, ``D -> [D, I]``; the innovations
            named ``e_<output>``, not delayed).
        name : str or None, optional
            The system's name (python-control's default when ``None``).
        pade_order : int or None, optional
            Dead times become ``(N, N)`` Pade approximants
            (:func:`hdpbsid.models.dead_time.pade`) in series with each delayed input,
            ``N = pade_order`` or, by default, :meth:`pade_order`; their ``N m`` states follow
            the model's ``n``.  The exact delayed response is :meth:`frequency_response` and
            :meth:`simulate`.

        Returns
        -------
        control.StateSpace
            With ``dt=0``.

        Raises
        ------
        ImportError
            If python-control is not installed.
        """
        control = import_control()
        A, B, C, D = with_pade(self, pade_order)
        inputs = list(self.input_names or [])
        if noise_inputs:
            K = np.vstack([self.K, np.zeros((A.shape[0] - self.n, self.l))])
            B, D = np.hstack([B, K]), np.hstack([D, np.eye(self.l)])
            inputs += innovation_names(inputs, list(self.output_names or []))
        return control.StateSpace(A, B, C, D, 0, **control_labels(inputs, self.output_names, name))


@dataclass(repr=False)
class DiscreteModel(_ModelBase):
    """Sampled innovation model ``x_{k+1} = A x_k + B u_k + K e_k``, ``y_k = C x_k + D u_k + e_k``.

    Parameters
    ----------
    A, B, C, D, K : array_like
        Shapes ``(n, n)``, ``(n, m)``, ``(l, n)``, ``(l, m)``, ``(n, l)``.
    singular_values, options, noise_covariance, u0, y0, trend, time_unit, input_names, output_names
        As in :class:`StateSpaceModel`.
    report : IdentificationReport or None, optional (keyword only)
        As in :class:`StateSpaceModel`.
    dt : float, optional
        Sampling interval in ``time_unit`` (``1.0`` when the index is just a sample count).

    Examples
    --------
    >>> from hdpbsid import DiscreteModel
    >>> model = DiscreteModel(A=[[0.5]], B=[[1.0]], C=[[1.0]], D=[[0.0]], K=[[0.0]], dt=0.1)
    >>> model.simulate([[1.0], [0.0], [0.0]]).ravel().tolist()  # impulse response 0, 1, 0.5
    [0.0, 1.0, 0.5]
    """

    dt: float = 1.0

    def __repr__(self) -> str:
        return f"DiscreteModel(dt={self.dt:g}, {self._repr_body()})"

    @library_call
    def simulate(self, u: Any, x0: Any | None = None, t: Any | None = None) -> Array:
        """Deterministic response to an input sequence.

        Parameters
        ----------
        u : array_like, shape (Ns, m)
            Absolute input: ``u0`` is removed and ``y0`` added (module docstring).
        x0 : array_like, shape (n,), optional
            Initial deviation state (default 0).
        t : array_like, shape (Ns,), optional
            The sample times; needed only when the model has a :class:`LinearTrend`.

        Returns
        -------
        ndarray, shape (Ns, l)
            The absolute output.

        Raises
        ------
        ValueError
            If ``u`` has the wrong number of columns, ``x0`` the wrong length, or the model has
            a trend and ``t`` is missing.
        """
        u = check_signal(u, "u", limit_energy=False)
        if u.shape[1] != self.m:
            raise ValueError(f"u must have {self.m} column(s) (inputs), got shape {u.shape}")
        if t is None:
            if self.trend is not None:
                raise ValueError("this model has a linear trend: pass the sample times t")
            t = np.zeros(u.shape[0])
        t = check_signal(t, "t", u.shape[0], limit_energy=False)[:, 0]
        U0, Y0 = self.operating_point(t)
        u = u - U0
        x = np.zeros(self.n) if x0 is None else as_float_array(x0, "x0").reshape(-1)
        if x.shape[0] != self.n:
            raise ValueError(f"x0 must have {self.n} entries, got {x.shape[0]}")
        X = linear_recursion(self.A, (u @ self.B.T)[:-1], x)
        return X @ self.C.T + u @ self.D.T + Y0

    def frequency_response(self, w: Any) -> NDArray[np.complex128]:
        r"""Frequency response :math:`G(e^{j\omega\,dt}) = C (e^{j\omega\,dt} I - A)^{-1} B + D`.

        Parameters
        ----------
        w : array_like, shape (nw,)
            Angular frequencies in rad per time unit.

        Returns
        -------
        ndarray of complex, shape (l, m, nw)
            The response, in python-control's layout.
        """
        w = as_float_array(w, "w").reshape(-1)
        return transfer(self.A, self.B, self.C, self.D, np.exp(1j * w * self.dt))

    def to_continuous(self) -> StateSpaceModel:
        """The exact zero-order-hold inverse (:func:`hdpbsid.models.conversion.d2c`).

        Returns
        -------
        StateSpaceModel
            With ``discrete`` set to this model and ``sampling_interval = dt``.

        Raises
        ------
        ValueError
            If ``A`` has an eigenvalue on or near the negative real axis or at zero (no real
            logarithm: :func:`~hdpbsid.models.conversion.check_log_exists`).
        """
        A, B, C, D, K = d2c(self.A, self.B, self.C, self.D, self.K, self.dt)
        return StateSpaceModel(
            A,
            B,
            C,
            D,
            K,
            singular_values=self.singular_values,
            options=dict(self.options),
            noise_covariance=self.noise_covariance,
            discrete=self,
            sampling_interval=self.dt,
            **self._offsets_kwargs(),
        )

    def to_scipy(self) -> Any:
        """The model as ``scipy.signal.StateSpace(A, B, C, D, dt=dt)``.

        Returns
        -------
        scipy.signal.StateSpace
            In deviations from the operating point (see :meth:`StateSpaceModel.to_scipy`).
        """
        from scipy.signal import StateSpace

        return StateSpace(self.A, self.B, self.C, self.D, dt=self.dt)

    def to_control(self, name: str | None = None) -> Any:
        """The model as ``control.StateSpace(A, B, C, D, dt)`` with named signals.

        Parameters
        ----------
        name : str or None, optional
            The system's name.

        Returns
        -------
        control.StateSpace
            In deviations from the operating point, signals named as in
            :meth:`StateSpaceModel.to_control`.
        """
        labels = control_labels(self.input_names, self.output_names, name)
        return import_control().StateSpace(self.A, self.B, self.C, self.D, self.dt, **labels)
