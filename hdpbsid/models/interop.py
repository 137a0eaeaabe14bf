"""A model in the forms of other libraries: transfer matrices, Pade-delayed state space,
python-control's named signals.

scipy and python-control have no dead time in a state-space model; a delayed input is
replaced by a ``(N, N)`` Pade approximant in series (Franklin, Powell & Emami-Naeini,
*Feedback Control of Dynamic Systems*, sec. 5.6), whose states follow the plant's
(:func:`with_pade`).  The exact delayed response stays with the model.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from hdpbsid.data.checks import check_label, check_positive_int
from hdpbsid.models.dead_time import pade

if TYPE_CHECKING:
    from hdpbsid.models.model import StateSpaceModel

__all__ = ["transfer", "with_pade", "innovation_names", "control_labels", "import_control"]

Array = NDArray[np.float64]


def transfer(A: Array, B: Array, C: Array, D: Array, s: NDArray[np.complex128]) -> Any:
    """The transfer matrix ``C (s I - A)^{-1} B + D`` at the points ``s``.

    Parameters
    ----------
    A, B, C, D : ndarray
        The state-space matrices, shapes ``(n, n)``, ``(n, m)``, ``(l, n)``, ``(l, m)``.
    s : ndarray of complex, shape (ns,)
        The points (``j w`` or ``e^{j w dt}``).

    Returns
    -------
    ndarray of complex, shape (l, m, ns)
        The response, in python-control's layout.
    """
    n = A.shape[0]
    if n == 0:
        return np.repeat(D[:, :, None].astype(complex), s.size, axis=2)
    M = s[:, None, None] * np.eye(n)[None] - A[None]
    X = np.linalg.solve(M, np.broadcast_to(B, (s.size,) + B.shape))
    G = np.einsum("ij,kjl->kil", C, X) + D[None]
    return np.moveaxis(G, 0, -1)


def _block_diag(blocks: list[Array]) -> Array:
    from scipy.linalg import block_diag

    return np.asarray(block_diag(*blocks), dtype=float).reshape(
        sum(b.shape[0] for b in blocks), sum(b.shape[1] for b in blocks)
    )


def with_pade(model: StateSpaceModel, order: int | None) -> tuple[Array, Array, Array, Array]:
    """``(A, B, C, D)`` with each delayed input through a Pade approximant.

    Parameters
    ----------
    model : StateSpaceModel
        The model.
    order : int or None
        The approximants' order (default :meth:`StateSpaceModel.pade_order`).

    Returns
    -------
    tuple of ndarray
        The matrices of the plant with the approximants before it, whose states follow
        the plant's; the model's own matrices without a delay or with ``order = 0``.

    Raises
    ------
    ValueError
        If ``order`` is negative.
    TypeError
        If ``order`` is not an int.
    """
    N = model.pade_order() if order is None else check_positive_int(order, "pade_order", 0)
    if not model.has_delay or N == 0:
        return model.A, model.B, model.C, model.D
    blocks = [pade(float(tau), N) for tau in model.delay]
    Ap = _block_diag([b[0] for b in blocks])
    Bp = _block_diag([b[1] for b in blocks])
    Cp = _block_diag([b[2] for b in blocks])
    Dp = np.diag([float(b[3][0, 0]) for b in blocks])
    n, q = model.n, Ap.shape[0]
    A = np.block([[model.A, model.B @ Cp], [np.zeros((q, n)), Ap]])
    B = np.vstack([model.B @ Dp, Bp])
    C = np.hstack([model.C, model.D @ Cp])
    return A, B, C, model.D @ Dp


def innovation_names(inputs: list[str], outputs: list[str]) -> list[str]:
    """``e_<output>`` for each output, made distinct from the input names.

    Parameters
    ----------
    inputs : list of str
        The input names.
    outputs : list of str
        The output names.

    Returns
    -------
    list of str
        One innovation name per output, an underscore prefixed until it is new.
    """
    names = []
    for o in outputs:
        e = f"e_{o}"
        while e in inputs or e in names:
            e = "_" + e
        names.append(e)
    return names


def control_labels(inputs: Any, outputs: Any, name: str | None) -> dict[str, Any]:
    """Keyword arguments naming the signals (and the system) of a python-control model.

    Parameters
    ----------
    inputs, outputs : list of str or None
        The signal names.
    name : str or None
        The system's name, if any.

    Returns
    -------
    dict
        ``inputs``, ``outputs`` and, when given, ``name``.

    Raises
    ------
    ValueError
        If ``name`` is blank or not printable.
    TypeError
        If ``name`` is not a string.
    """
    labels: dict[str, Any] = {"inputs": list(inputs or []), "outputs": list(outputs or [])}
    if name is not None:
        labels["name"] = check_label(name, "name")
    return labels


def import_control() -> Any:
    """The ``control`` package (python-control).

    Returns
    -------
    module
        ``control``.

    Raises
    ------
    ImportError
        If python-control is not installed, with the command that installs it.
    """
    try:
        import control
    except ImportError as exc:  # pragma: no cover - control is in the test extra
        raise ImportError(
            "to_control() needs python-control: pip install 'slbasis-hdpbsid[studies]' "
            "or pip install control"
        ) from exc
    return control
