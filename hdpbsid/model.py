"""Identified models: continuous-time :class:`StateSpaceModel` and sampled :class:`DiscreteModel`.

Both hold the innovation form ``x' = A x + B u + K e``, ``y = C x + D u + e`` (``x'`` is
``dx/dt`` or ``x_{k+1}``), the singular values the order was chosen from and the
``options`` actually used.  Simulation, fit statistics, frequency responses and
conversions to scipy / python-control live here; identification lives elsewhere.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.linalg import expm

from .checks import as_float_array, check_signal, check_state_space, check_time
from .conversion import c2d, d2c

__all__ = ["StateSpaceModel", "DiscreteModel", "FitResult", "fit_statistics"]

Array = NDArray[np.float64]


@dataclass
class FitResult:
    """Simulation fit of a model on a record.

    ``vaf`` (percent, per output) ``= 100 (1 - var(y - y_sim) / var(y))``;
    ``nrmse`` (per output) ``= ||y - y_sim|| / ||y - mean(y)||`` (MATLAB's ``fit`` is
    ``100 (1 - nrmse)``); ``y_sim`` the simulated output; ``x0`` the initial state used.
    """

    vaf: Array
    nrmse: Array
    y_sim: Array
    x0: Array

    def __repr__(self) -> str:
        return (
            f"FitResult(vaf={np.array2string(self.vaf, precision=2)} %, "
            f"nrmse={np.array2string(self.nrmse, precision=4)})"
        )


def fit_statistics(y: Array, y_sim: Array) -> tuple[Array, Array]:
    """VAF (percent) and NRMSE per output column of ``y`` (Ns, l) vs ``y_sim``."""
    err = y - y_sim
    var_y = np.var(y, axis=0)
    safe = np.where(var_y > 0, var_y, np.nan)
    vaf = 100.0 * (1.0 - np.var(err, axis=0) / safe)
    nrmse = np.linalg.norm(err, axis=0) / np.sqrt(safe * y.shape[0])
    return vaf, nrmse


def _fmt_eigs(ev: NDArray[np.complex128], limit: int = 8) -> str:
    parts = []
    for lam in ev[:limit]:
        if abs(lam.imag) <= 1e-12 * max(1.0, abs(lam)):
            parts.append(f"{lam.real:.6g}")
        else:
            parts.append(f"{lam.real:.6g}{lam.imag:+.6g}j")
    more = f", ... ({ev.size} total)" if ev.size > limit else ""
    return "[" + ", ".join(parts) + more + "]"


def _sort_eigs(ev: NDArray[np.complex128]) -> NDArray[np.complex128]:
    return ev[np.lexsort((ev.imag, ev.real))]


@dataclass(repr=False)
class _ModelBase:
    A: Array
    B: Array
    C: Array
    D: Array
    K: Array
    singular_values: Array | None = None
    options: dict[str, Any] = field(default_factory=dict)
    noise_covariance: Array | None = None

    def __post_init__(self) -> None:
        self.A, self.B, self.C, self.D, self.K = check_state_space(
            self.A, self.B, self.C, self.D, self.K
        )

    @property
    def n(self) -> int:
        """State dimension."""
        return self.A.shape[0]

    @property
    def m(self) -> int:
        """Number of inputs."""
        return self.B.shape[1]

    @property
    def l(self) -> int:  # noqa: E743 - l is the standard name for the number of outputs
        """Number of outputs."""
        return self.C.shape[0]

    @property
    def eigenvalues(self) -> NDArray[np.complex128]:
        """Eigenvalues of ``A`` sorted by real then imaginary part."""
        return _sort_eigs(np.linalg.eigvals(self.A))

    def _repr_body(self) -> str:
        return f"n={self.n}, m={self.m}, l={self.l}, eigenvalues={_fmt_eigs(self.eigenvalues)}"


@dataclass(repr=False)
class StateSpaceModel(_ModelBase):
    """Continuous-time innovation model ``dx/dt = A x + B u + K e``, ``y = C x + D u + e``.

    Attributes: ``A (n, n)``, ``B (n, m)``, ``C (l, n)``, ``D (l, m)``, ``K (n, l)``,
    ``singular_values`` (of the SVD step, for order selection), ``options`` (every
    setting actually used, defaults included), ``noise_covariance`` (innovation
    covariance estimate, ``None`` if unknown) and ``discrete`` (the sampled model it was
    converted from, if any).  ``K`` follows the hold convention of
    :mod:`hdpbsid.conversion`.
    """

    discrete: DiscreteModel | None = None

    def __repr__(self) -> str:
        method = self.options.get("method")
        extra = f", method={method!r}" if method else ""
        return f"StateSpaceModel(continuous, {self._repr_body()}{extra})"

    # -- simulation ------------------------------------------------------------------
    def _step_matrices(self, h: Array, method: str) -> tuple[Array, Array, Array | None]:
        """Exact one-step matrices for steps ``h``: ZOH ``(Phi, G, None)`` or FOH
        ``(Phi, G1, G2)`` from the augmented exponentials (Franklin-Powell-Workman 6.3):
        ``expm([[A h, B h], [0, 0]])`` resp. ``expm([[A h, B h, 0], [0, 0, I], [0, 0, 0]])``.
        """
        n, m = self.n, self.m
        size = n + m if method == "zoh" else n + 2 * m
        M = np.zeros((h.size, size, size))
        M[:, :n, :n] = self.A[None] * h[:, None, None]
        M[:, :n, n : n + m] = self.B[None] * h[:, None, None]
        if method == "foh":
            M[:, n : n + m, n + m :] = np.eye(m)[None]
        E = expm(M)
        G2 = E[:, :n, n + m :] if method == "foh" else None
        return E[:, :n, :n], E[:, :n, n : n + m], G2

    def simulate(
        self,
        t: Any,
        u: Any,
        x0: Any | None = None,
        method: str = "zoh",
        return_states: bool = False,
    ) -> Array | tuple[Array, Array]:
        """Deterministic response (``e = 0``) at the times ``t`` (need not be uniform).

        ``method="zoh"``: ``u[k]`` held on ``[t_k, t_{k+1})`` (the assumption under which
        :func:`~hdpbsid.identify_dt` data are sampled); ``method="foh"``: ``u`` linear
        between samples, as :func:`scipy.signal.lsim` does by default.  Each step uses
        the exact exponential of the augmented matrix for its own ``h = t_{k+1} - t_k``
        (steps equal to 1e-12 relative share one exponential).  Returns ``y (Ns, l)``
        (and ``x (Ns, n)`` with ``return_states``).
        """
        if method not in ("zoh", "foh"):
            raise ValueError(f"method must be 'zoh' or 'foh', got {method!r}")
        t = check_time(t, "t", min_samples=1)
        ns, n = t.shape[0], self.n
        if self.m == 0 and u is None:
            u = np.zeros((ns, 0))
        u = check_signal(u, "u", ns)
        if u.shape[1] != self.m:
            raise ValueError(f"u must have {self.m} column(s) (inputs), got shape {u.shape}")
        x = np.zeros(n) if x0 is None else as_float_array(x0, "x0").reshape(-1)
        if x.shape[0] != n:
            raise ValueError(f"x0 must have {n} entries (the state dimension), got {x.shape[0]}")
        X = np.empty((ns, n))
        X[0] = x
        if ns > 1:
            h = np.diff(t)
            key = np.round(h / np.max(h), 12)
            uniq, inv = np.unique(key, return_inverse=True)
            first = np.array([np.flatnonzero(inv == i)[0] for i in range(uniq.size)])
            Phi, G1, G2 = self._step_matrices(h[first], method)
            Bu = np.einsum("kij,kj->ki", G1[inv], u[:-1])
            if G2 is not None:
                Bu += np.einsum("kij,kj->ki", G2[inv], np.diff(u, axis=0))
            if uniq.size == 1:
                P = Phi[0]
                for k in range(ns - 1):
                    x = P @ x + Bu[k]
                    X[k + 1] = x
            else:
                for k in range(ns - 1):
                    x = Phi[inv[k]] @ x + Bu[k]
                    X[k + 1] = x
        y = X @ self.C.T + u @ self.D.T
        return (y, X) if return_states else y

    def fit(self, t: Any, u: Any, y: Any, x0: Any = "estimate", method: str = "zoh") -> FitResult:
        """Simulate on ``(t, u)`` and compare with ``y``: VAF and NRMSE per output.

        ``x0="estimate"`` (default) fits the initial state by least squares (the output
        is affine in ``x0``); ``"zero"`` or an array use that state.
        """
        t = check_time(t, "t")
        y = check_signal(y, "y", t.shape[0])
        if y.shape[1] != self.l:
            raise ValueError(f"y must have {self.l} column(s) (outputs), got shape {y.shape}")
        if isinstance(x0, str):
            if x0 not in ("estimate", "zero"):
                raise ValueError(f"x0 must be 'estimate', 'zero' or an array, got {x0!r}")
            x0v = np.zeros(self.n)
            y0 = self.simulate(t, u, x0v, method=method)
            if x0 == "estimate" and self.n > 0:
                ufree = np.zeros((t.shape[0], self.m))
                O = np.stack(
                    [
                        self.simulate(t, ufree, np.eye(self.n)[i], method=method).ravel()
                        for i in range(self.n)
                    ],
                    axis=1,
                )
                x0v = np.linalg.lstsq(O, (y - y0).ravel(), rcond=None)[0]
                y0 = y0 + (O @ x0v).reshape(y.shape)
        else:
            x0v = as_float_array(x0, "x0").reshape(-1)
            y0 = self.simulate(t, u, x0v, method=method)
        vaf, nrmse = fit_statistics(y, y0)
        return FitResult(vaf=vaf, nrmse=nrmse, y_sim=y0, x0=x0v)

    # -- frequency domain and conversions -----------------------------------------------
    def frequency_response(self, w: Any) -> NDArray[np.complex128]:
        """``G(jw) = C (jw I - A)^{-1} B + D`` for angular frequencies ``w`` (rad/s).

        Returns a complex array of shape ``(l, m, len(w))`` (python-control layout).
        """
        w = as_float_array(w, "w").reshape(-1)
        s = 1j * w
        return _transfer(self.A, self.B, self.C, self.D, s)

    def to_discrete(self, dt: float) -> DiscreteModel:
        """ZOH sampling (:func:`hdpbsid.conversion.c2d`, ``K`` by the hold convention)."""
        Ad, Bd, C, D, Kd = c2d(self.A, self.B, self.C, self.D, self.K, dt)
        return DiscreteModel(Ad, Bd, C, D, Kd, dt=float(dt), options={"from": "c2d (zoh)"})

    def to_scipy(self) -> Any:
        """``scipy.signal.StateSpace(A, B, C, D)`` (continuous; the ``u -> y`` part)."""
        from scipy.signal import StateSpace

        return StateSpace(self.A, self.B, self.C, self.D)

    def to_control(self, noise_inputs: bool = False) -> Any:
        """``control.StateSpace`` with ``dt=0``; with ``noise_inputs`` the inputs are
        ``[u, e]`` (``B -> [B, K]``, ``D -> [D, I]``)."""
        control = _import_control()
        B, D = self.B, self.D
        if noise_inputs:
            B, D = np.hstack([B, self.K]), np.hstack([D, np.eye(self.l)])
        return control.StateSpace(self.A, B, self.C, D, 0)


@dataclass(repr=False)
class DiscreteModel(_ModelBase):
    """Sampled innovation model ``x_{k+1} = A x_k + B u_k + K e_k``, ``y_k = C x_k + D u_k
    + e_k`` with sampling interval ``dt`` (``1.0`` when the index is just a sample count).
    """

    dt: float = 1.0

    def __repr__(self) -> str:
        return f"DiscreteModel(dt={self.dt:g}, {self._repr_body()})"

    def simulate(self, u: Any, x0: Any | None = None) -> Array:
        """Deterministic response ``y (Ns, l)`` to ``u (Ns, m)`` from ``x0`` (default 0)."""
        u = check_signal(u, "u")
        if u.shape[1] != self.m:
            raise ValueError(f"u must have {self.m} column(s) (inputs), got shape {u.shape}")
        x = np.zeros(self.n) if x0 is None else as_float_array(x0, "x0").reshape(-1)
        if x.shape[0] != self.n:
            raise ValueError(f"x0 must have {self.n} entries, got {x.shape[0]}")
        X = np.empty((u.shape[0], self.n))
        Bu = u @ self.B.T
        for k in range(u.shape[0]):
            X[k] = x
            x = self.A @ x + Bu[k]
        return X @ self.C.T + u @ self.D.T

    def frequency_response(self, w: Any) -> NDArray[np.complex128]:
        """``G(e^{jw dt})`` for angular frequencies ``w`` (rad per time unit); (l, m, nw)."""
        w = as_float_array(w, "w").reshape(-1)
        return _transfer(self.A, self.B, self.C, self.D, np.exp(1j * w * self.dt))

    def to_continuous(self) -> StateSpaceModel:
        """Exact ZOH inverse (:func:`hdpbsid.conversion.d2c`)."""
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
        )

    def to_scipy(self) -> Any:
        """``scipy.signal.StateSpace(A, B, C, D, dt=dt)``."""
        from scipy.signal import StateSpace

        return StateSpace(self.A, self.B, self.C, self.D, dt=self.dt)

    def to_control(self) -> Any:
        """``control.StateSpace(A, B, C, D, dt)``."""
        return _import_control().StateSpace(self.A, self.B, self.C, self.D, self.dt)


def _transfer(A: Array, B: Array, C: Array, D: Array, s: NDArray[np.complex128]) -> Any:
    n = A.shape[0]
    if n == 0:
        return np.repeat(D[:, :, None].astype(complex), s.size, axis=2)
    M = s[:, None, None] * np.eye(n)[None] - A[None]
    X = np.linalg.solve(M, np.broadcast_to(B, (s.size,) + B.shape))
    G = np.einsum("ij,kjl->kil", C, X) + D[None]
    return np.moveaxis(G, 0, -1)


def _import_control() -> Any:
    try:
        import control
    except ImportError as exc:  # pragma: no cover - control is in the test extra
        raise ImportError(
            "to_control() needs python-control: pip install 'slbasis-hdpbsid[studies]' "
            "or pip install control"
        ) from exc
    return control
