"""The ablation of the decision rules (``bench/ablation.py``): its switches, one run and
its comparison.

Oracles: the library's own attributes (a switch replaces them inside the block and
restores them after it); hand-made CSV tables whose verdicts follow from the margin rule
of ``bench/regression.py`` by arithmetic; the unchanged library's row of the same
record.  No timing is asserted.
"""

from __future__ import annotations

import json
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
from threadpoolctl import threadpool_limits

BENCH = Path(__file__).resolve().parents[2] / "bench"
sys.path.insert(0, str(BENCH))

import ablation as AB  # noqa: E402
import regression as R  # noqa: E402

#: the outcome columns of a row (``/work/regdiff.py``'s: the CPU times differ run to run)
OUTCOME = ("method", "order", "order_found", "err_pct", "fit_pct", "stable", "error")


@pytest.fixture(autouse=True)
def _one_blas_thread() -> Iterator[None]:
    """As the bench runs its records."""
    with threadpool_limits(limits=1):
        yield


def _current(owner: object, attr: str) -> object:
    return owner.__dict__[attr] if isinstance(owner, type) else getattr(owner, attr)


@pytest.mark.parametrize("name", [n for n, r in AB.RULES.items() if not r.removed])
def test_switch_replaces_and_restores(name: str) -> None:
    """Every switch names attributes the library has, replaces them inside the block and
    restores them after it (a renamed function surfaces here, not as a silent no-op)."""
    rule = AB.RULES[name]
    patches = rule.patches()
    assert patches
    before = [_current(owner, attr) for owner, attr, _ in patches]
    with AB.switched_off(rule):
        for (owner, attr, _), old in zip(patches, before, strict=True):
            now = _current(owner, attr)
            assert callable(now) and now is not old
    assert [_current(owner, attr) for owner, attr, _ in patches] == before


def test_switch_restores_after_an_exception() -> None:
    rule = AB.RULES["tie_break"]
    ((owner, attr, _),) = rule.patches()
    old = _current(owner, attr)
    with pytest.raises(RuntimeError), AB.switched_off(rule):
        raise RuntimeError("inside")
    assert _current(owner, attr) is old


def _row(id_: str, **kw: object) -> dict[str, str]:
    row = dict.fromkeys(R.CSV_FIELDS, "")
    row.update(
        id=id_, family="f", true_order="2", method="hermite", order="2", order_found="True",
        err_pct="1.0", fit_pct="90.0", stable="True", true_stable="True", cpu_s="0.5",
    )  # fmt: skip
    row.update({k: str(v) for k, v in kw.items()})
    return row


BASE = [_row("a"), _row("b"), _row("c")]


@pytest.mark.parametrize(
    ("rows", "expected", "counts"),
    [
        (BASE, "no effect", {}),
        ([_row("a", method="dt"), _row("b"), _row("c")], "neutral", {"changed": 1}),
        ([_row("a", err_pct=0.5), _row("b"), _row("c")], "hurts", {"better": 1}),
        # one row worse, one better: a trade, the rule stays
        (
            [_row("a", err_pct=0.5), _row("b", order=3, order_found=False, err_pct=""), _row("c")],
            "earns its place",
            {"better": 1, "worse": 1},
        ),
        (
            [_row("a", err_pct=5.0, fit_pct=99.0), _row("b"), _row("c")],
            "earns its place",
            {"mixed": 1},
        ),
    ],
)
def test_verdict_follows_the_rows(
    rows: list[dict[str, str]], expected: str, counts: dict[str, int]
) -> None:
    out = AB.compare("tie_break", BASE, rows, {"a": 1, "b": 0, "c": 2})
    assert AB.verdict(out) == expected
    for v in ("worse", "mixed", "better", "changed"):
        assert out.count(v) == counts.get(v, 0)
    assert out.rows == 3 and out.reached == 2


def test_compare_uses_the_rows_of_the_run_only() -> None:
    """A subset run is compared with the baseline's rows of that subset only."""
    out = AB.compare("tie_break", [*BASE, _row("d", err_pct=50.0)], [_row("a"), _row("b")])
    assert out.rows == 2 and out.changes == [] and out.reached is None
    assert out.totals["err_median"][:2] == (1.0, 1.0)


def test_one_rule_on_a_tiny_record() -> None:
    """A rule switched off on one quick record: the switch is reached, and where it cannot
    change a decision (one candidate tied) the row is the unchanged library's."""
    spec = R.select(R.record_specs(), ["random/000"])
    rows, calls = AB.run_rule("tie_break", spec)
    plain, none = AB.run_rule(None, spec)
    assert calls == {"random/000": 1} and none == {"random/000": 0}
    assert rows[0]["error"] == "" and rows[0]["order"].isdigit()
    assert [rows[0][k] for k in OUTCOME] == [plain[0][k] for k in OUTCOME]
    assert AB.verdict(AB.compare("tie_break", plain, rows, calls)) == "no effect"


def test_main_writes_the_rule_and_the_report(tmp_path: Path) -> None:
    """One rule on one record through the command line, then the report rebuilt from the
    CSVs alone (``--report-only``) is the same table."""
    base, out, csvs = tmp_path / "base.csv", tmp_path / "a.md", tmp_path / "csv"
    R.write_csv(AB.run_rule(None, R.select(R.record_specs(), ["random/000"]))[0], base)
    args = ["--rules", "refit_growth", "--subset", "random/000", "--base", str(base)]
    assert AB.main([*args, "--out", str(out), "--csv-dir", str(csvs)]) == 0
    assert [r["id"] for r in R.read_csv(csvs / "refit_growth.csv")] == ["random/000"]
    assert set(json.loads((csvs / "refit_growth.json").read_text())["calls"]) == {"random/000"}
    text = out.read_text()
    assert "| `refit_growth` |" in text and "no effect" in text
    again = tmp_path / "b.md"
    assert (
        AB.main(["--report-only", "--base", str(base), "--out", str(again), "--csv-dir", str(csvs)])
        == 0
    )
    table = [line for line in text.splitlines() if line.startswith("| `")]
    assert [line for line in again.read_text().splitlines() if line.startswith("| `")] == table


def test_a_removed_rule_switches_nothing() -> None:
    """A rule removed from the library keeps its measured rows; its switch is a no-op."""
    rule = AB.Rule("gone", "-", "-", "-", lambda: [(object(), "nothing", None)], removed=True)
    with AB.switched_off(rule):
        pass
    out = AB.compare("gone", BASE, BASE)
    assert AB.verdict(out) == "no effect"
