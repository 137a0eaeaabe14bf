"""The block core from factors accumulated per batch (hdpbsid.core.streamed).

Oracle: the in-memory block core (hdpbsid.core.blocks: select_past_window_blocks,
varx_stage_blocks, pbsid_core_blocks) on the same blocks, all columns at once, and the
true system the blocks were simulated from.
"""

from __future__ import annotations

import numpy as np
import pytest

from hdpbsid.core import streamed
from hdpbsid.core.blocks import (
    BlockLag,
    BlockPseudo,
    pbsid_core_blocks,
    select_past_window_blocks,
)
from hdpbsid.core.varx import MatrixLag

N_BLOCK, K_BLOCKS = 80, 12
A_TRUE = np.array([[0.9, 0.25], [-0.25, 0.9]])
B_TRUE = np.array([[0.0], [1.0]])
C_TRUE = np.array([[1.0, 0.0]])
K_TRUE = np.array([[0.3], [0.1]])


def _blocks(seed: int = 0):
    """``K_BLOCKS`` records of a second-order innovation model, each from its own unknown
    initial state: one block each, lag = the sample shift inside the block (``M`` with
    ones on the superdiagonal), pseudo row = the first column (the initial state enters
    ``x = A lag(x) + B lag(u) + K lag(e)`` there only)."""
    rng = np.random.default_rng(seed)
    U, Y = [], []
    for _ in range(K_BLOCKS):
        x = rng.standard_normal(2)
        u = rng.standard_normal(N_BLOCK)
        e = 0.05 * rng.standard_normal(N_BLOCK)
        y = np.empty(N_BLOCK)
        for k in range(N_BLOCK):
            y[k] = (C_TRUE @ x)[0] + e[k]
            x = A_TRUE @ x + B_TRUE[:, 0] * u[k] + K_TRUE[:, 0] * e[k]
        U.append(u)
        Y.append(y)
    shift = MatrixLag(np.eye(N_BLOCK, k=1))
    P = np.eye(1, N_BLOCK)
    return np.concatenate(U)[None, :], np.concatenate(Y)[None, :], shift, P


def _batch(U, Y, lag, P, blocks):
    cols = np.concatenate([np.arange(b * N_BLOCK, (b + 1) * N_BLOCK) for b in blocks])
    bl = BlockLag([lag] * len(blocks), [N_BLOCK] * len(blocks))
    return U[:, cols], Y[:, cols], bl, BlockPseudo(bl, [P] * len(blocks))


def _streamed(U, Y, lag, P, partition, p, ps=(2, 3, 4), regularize="gcv", order=2, stable_k=False):
    vf = None
    for blocks in partition:
        vf = streamed.merge(vf, streamed.varx_factors(*_batch(U, Y, lag, P, blocks), list(ps)))
    vs = streamed.solve_varx(vf, 1, 1, p, p, regularize, 1e-6, normalize=False)
    sf = None
    for blocks in partition:
        sf = streamed.merge(sf, streamed.state_factors(*_batch(U, Y, lag, P, blocks), vs))
    return vf, vs, streamed.solve_model(vs, sf, 1, 1, order, None, 1e-6, stable_k)


def _signed(model, ref):
    j = np.argmax(np.abs(ref.C), axis=0)
    T = np.diag(np.sign(model.C[j, np.arange(ref.C.shape[1])] * ref.C[j, np.arange(2)]))
    return T @ model.A @ T, T @ model.B, model.C @ T, T @ model.K


def _rel(a, b) -> float:
    return float(np.abs(a - b).max() / np.abs(b).max())


# both sides are orthogonal reductions of the same columns (Householder QR, backward
# stable) followed by the same small solves: rounding times the conditioning of the
# VARX and state regressions (~1e3 here) stays far below 1e-9
SAME = 1e-9


@pytest.mark.parametrize("regularize", ["gcv", False, 0.5])
def test_streamed_core_is_the_in_memory_core(regularize) -> None:
    U, Y, lag, P = _blocks()
    all_blocks = list(range(K_BLOCKS))
    _, bl, pseudo = _batch(U, Y, lag, P, all_blocks)[1:]
    ref = pbsid_core_blocks(U, Y, 3, bl, pseudo, order=2, regularize=regularize, ridge_floor=1e-6)
    vf, vs, got = _streamed(
        U, Y, lag, P, [[0, 1, 2], [3], [4, 5, 6, 7, 8, 9, 10, 11]], 3, regularize=regularize
    )
    assert vf.ncols == U.shape[1] and vf.batches == 3
    assert _rel(vs.theta[:, :8], ref.varx.coef) < SAME
    assert abs(vs.ridge - ref.varx.ridge) <= SAME * max(ref.varx.ridge, 1e-300)
    assert _rel(got.singular_values, ref.singular_values) < SAME
    for a, b in zip(_signed(got, ref), (ref.A, ref.B, ref.C, ref.K), strict=True):
        assert _rel(a, b) < SAME
    assert _rel(got.noise_covariance, ref.noise_covariance) < SAME
    # and both are the system: 960 samples, innovation std 0.05 (a few % on A)
    assert np.allclose(
        np.sort_complex(np.linalg.eigvals(got.A)),
        np.sort_complex(np.linalg.eigvals(A_TRUE)),
        atol=0.03,
    )


def test_aic_of_every_p_is_the_in_memory_aic() -> None:
    U, Y, lag, P = _blocks(1)
    scale = np.sqrt(np.mean(U**2)), np.sqrt(np.mean(Y**2))
    _, bl, pseudo = _batch(U, Y, lag, P, list(range(K_BLOCKS)))[1:]
    # in memory on the normalised rows, as run_core calls it
    p_ref, crit_ref = select_past_window_blocks(U / scale[0], Y / scale[1], 4, 2, bl, pseudo)
    vf = None
    for blocks in ([0, 5], [1, 2, 3, 4], [6, 7, 8, 9, 10, 11]):
        vf = streamed.merge(vf, streamed.varx_factors(*_batch(U, Y, lag, P, blocks), [2, 3, 4]))
    p, crit = streamed.select_p(vf, 1, 1, 2, 4, normalize=True)
    assert p == p_ref
    # AIC values ~ -1e4: differences of rounding in log det, far below 1e-9 relative
    np.testing.assert_allclose(crit[1:], crit_ref[1:], rtol=1e-9)
    assert np.isinf(crit[0]) and np.isinf(crit_ref[0])


def test_result_does_not_depend_on_the_batching() -> None:
    U, Y, lag, P = _blocks(2)
    one = _streamed(U, Y, lag, P, [list(range(K_BLOCKS))], 3)[2]
    many = _streamed(U, Y, lag, P, [[b] for b in range(K_BLOCKS)], 3)[2]
    # no sign alignment: the state signs follow a rule on S, not on the batches
    for name in ("A", "B", "C", "K"):
        assert _rel(getattr(many, name), getattr(one, name)) < SAME, name


def test_factors_do_not_grow_with_the_blocks() -> None:
    U, Y, lag, P = _blocks(3)
    few = _streamed(U, Y, lag, P, [[0, 1], [2]], 3)[0]
    many = _streamed(U, Y, lag, P, [[b] for b in range(K_BLOCKS)], 3)[0]
    for p in (2, 3, 4):
        # (p (m + l) + l) square: the regressors and target, whatever the column count
        assert few.hard[p].shape == many.hard[p].shape == (2 * p + 1, 2 * p + 1)
        assert {k: v.shape for k, v in few.soft[p].items()} == {
            k: v.shape for k, v in many.soft[p].items()
        }


def test_lags_that_invalidate_columns_are_refused() -> None:
    from hdpbsid.bases.basis_domain import BlockShift

    U, Y, _, P = _blocks()
    bl = BlockLag([BlockShift(N_BLOCK)], [U.shape[1]])
    with pytest.raises(ValueError, match="keep every column valid"):
        streamed.varx_factors(U, Y, bl, None, [2])


def test_merge_with_nothing_is_identity() -> None:
    U, Y, lag, P = _blocks()
    vf = streamed.varx_factors(*_batch(U, Y, lag, P, [0, 1]), [2])
    assert streamed.merge(None, vf) is vf and streamed.merge(vf, None) is vf


def test_stable_k_is_the_in_memory_riccati_gain() -> None:
    U, Y, lag, P = _blocks(4)
    _, bl, pseudo = _batch(U, Y, lag, P, list(range(K_BLOCKS)))[1:]
    kw = {"order": 2, "regularize": "gcv", "ridge_floor": 1e-6}
    ref = pbsid_core_blocks(U, Y, 3, bl, pseudo, stable_k=True, **kw)
    ls = pbsid_core_blocks(U, Y, 3, bl, pseudo, **kw)
    got = _streamed(U, Y, lag, P, [[0, 1, 2, 3], [4, 5], [6, 7, 8, 9, 10, 11]], 3, stable_k=True)
    assert got[2].options["k_method"] == ref.options["k_method"] == "riccati"
    K_got = _signed(got[2], ref)[3]
    assert _rel(K_got, ref.K) < SAME
    assert _rel(ls.K, ref.K) > 1e3 * SAME  # the Riccati gain is not the least-squares one


def test_blocks_of_equal_size_and_different_pseudo_rows() -> None:
    """Two kinds of blocks with the same column count: their nuisance directions and
    singular values differ, so their ridge columns must be scaled apart."""
    U, Y, lag, P = _blocks(5)
    P2 = np.array([[2.0, 1.0] + [0.0] * (N_BLOCK - 2)])  # another initial-condition row
    rows = [P] * 6 + [P2] * 6
    bl = BlockLag([lag] * K_BLOCKS, [N_BLOCK] * K_BLOCKS)
    ref = pbsid_core_blocks(
        U, Y, 3, bl, BlockPseudo(bl, rows), order=2, regularize="gcv", ridge_floor=1e-6
    )
    assert ref.varx.ridge > 0  # the ridge columns matter

    def run(partition, labels):
        vf = sf = None
        for blocks in partition:
            cols = np.concatenate([np.arange(b * N_BLOCK, (b + 1) * N_BLOCK) for b in blocks])
            b_lag = BlockLag([lag] * len(blocks), [N_BLOCK] * len(blocks))
            pseudo = BlockPseudo(b_lag, [rows[b] for b in blocks])
            kinds = [labels[b] for b in blocks]
            vf = streamed.merge(
                vf, streamed.varx_factors(U[:, cols], Y[:, cols], b_lag, pseudo, [3], kinds)
            )
        vs = streamed.solve_varx(vf, 1, 1, 3, 3, "gcv", 1e-6, normalize=False)
        for blocks in partition:
            cols = np.concatenate([np.arange(b * N_BLOCK, (b + 1) * N_BLOCK) for b in blocks])
            b_lag = BlockLag([lag] * len(blocks), [N_BLOCK] * len(blocks))
            pseudo = BlockPseudo(b_lag, [rows[b] for b in blocks])
            sf = streamed.merge(
                sf, streamed.state_factors(U[:, cols], Y[:, cols], b_lag, pseudo, vs)
            )
        return vs, streamed.solve_model(vs, sf, 1, 1, 2, None, 1e-6)

    labels = ["first"] * 6 + ["second"] * 6
    vs, got = run([[0, 7, 1], [2, 3, 8, 9], [4, 5, 6, 10, 11]], labels)
    assert _rel(vs.theta, ref.varx.coef) < SAME
    for a, b in zip(_signed(got, ref), (ref.A, ref.B, ref.C, ref.K), strict=True):
        assert _rel(a, b) < SAME
    # one label for both kinds is caught, not silently mixed
    with pytest.raises(ValueError, match="different pseudo rows"):
        run([list(range(K_BLOCKS))], ["same"] * K_BLOCKS)
