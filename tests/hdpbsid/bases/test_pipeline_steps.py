"""The pipeline's steps shared with the chunked path (hdpbsid.bases.pipeline)."""

from __future__ import annotations

import numpy as np

from hdpbsid.bases.family import Integrator, size_policy
from hdpbsid.bases.hermite_family import HermiteFamily
from hdpbsid.bases.pipeline import block_kinds, lag, make_blocks, size_bases, stacked
from hdpbsid.data.records import as_records


def _blocks():
    t = np.arange(0.0, 20.0, 0.01)
    rng = np.random.default_rng(0)
    u, y = rng.standard_normal(t.size), rng.standard_normal(t.size)
    family = HermiteFamily()
    records = as_records(t, u, y)
    return family, make_blocks(records, family, 5.0, None, size_policy(family, 40, 10.0))


def test_size_bases_is_make_blocks_sizing():
    family, blocks = _blocks()
    spans = {}
    for key, seg in zip(blocks.keys, blocks.segs, strict=True):
        spans.setdefault(key, (seg.duration, seg.ns))
    bases, sizes = size_bases(family, size_policy(family, 40, 10.0), spans)
    assert list(bases) == list(blocks.bases)
    assert [b.N for b in bases.values()] == [b.N for b in blocks.bases.values()]
    assert [c.reason for c in sizes.values()] == [c.reason for c in blocks.sizes.values()]


def test_stacked_kinds_give_the_pipeline_lag():
    family, blocks = _blocks()
    op = Integrator(4.0, 1.0, 1.0)
    kinds = block_kinds(family, blocks.bases, op, True)
    L, rows = stacked(kinds, blocks.keys)
    L0 = lag(blocks, op)
    assert L.sizes == L0.sizes
    W = np.random.default_rng(1).standard_normal((2, sum(L.sizes)))
    assert np.array_equal(L.apply(W, 1), L0.apply(W, 1))
    assert len(rows) == len(blocks.keys)
    assert all(r.shape[1] == kinds[k].N for r, k in zip(rows, blocks.keys, strict=True))
