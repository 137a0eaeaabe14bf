"""``bench/user.py``'s plumbing: the columns alternate, results of several processes
merge, the table is written as markdown with its command and the load average.  No time
is asserted (the bench prints times; tests check what it does with them)."""

from __future__ import annotations

import sys
from pathlib import Path

BENCH = Path(__file__).resolve().parents[2] / "bench"
sys.path.insert(0, str(BENCH))

import user as U  # noqa: E402


def test_columns_alternate_so_a_drift_shifts_both_alike():
    calls: list[tuple[bool, int]] = []

    def run(one: bool, i: int) -> dict:
        calls.append((one, i))
        return {"wall": [float(i)], "cpu": [10.0 + i]}

    got = U._alternate(4, run)
    # ABBA ABBA: each column runs first in half of the pairs
    assert calls == [(False, 0), (True, 0), (True, 1), (False, 1)] + [
        (False, 2),
        (True, 2),
        (True, 3),
        (False, 3),
    ]
    assert (
        got[False] == got[True] == {"wall": [0.0, 1.0, 2.0, 3.0], "cpu": [10.0, 11.0, 12.0, 13.0]}
    )


def test_merge_keeps_nested_lists_and_a_failure():
    a = {"n4sid": {"wall": [1.0], "err": [0.1]}, "hdpbsid": {"wall": [2.0], "err": [0.2]}}
    b = {"n4sid": {"wall": [3.0], "err": [0.3]}, "hdpbsid": {"wall": [4.0], "err": [0.4]}}
    assert U._merge([a, b]) == {
        "n4sid": {"wall": [1.0, 3.0], "err": [0.1, 0.3]},
        "hdpbsid": {"wall": [2.0, 4.0], "err": [0.2, 0.4]},
    }
    assert U._merge([a, {"status": "failed: x"}]) == {"status": "failed: x"}


def test_table_is_written_as_markdown_with_its_command_and_load(tmp_path: Path, capsys):
    md = tmp_path / "user.md"
    assert U.main(["--rows", "import", "--reps", "1", "--md", str(md)]) == 0
    text = md.read_text()
    head, table = text.split("\n\n")[:2]
    assert f"`python bench/user.py --rows import --reps 1 --md {md}`" in head
    assert "load average (1, 5, 15 min)" in head and "at the end" in text
    rows = table.splitlines()
    assert rows[0].startswith("| row | default wall s") and len(rows) == 3
    cells = rows[2].split("|")[1:-1]
    assert cells[0].strip() == "process: import hdpbsid" and len(cells) == 7
    assert all(float(c) > 0 for c in cells[1:])  # times and ratios were measured


def test_ratio_line_divides_medians_and_counts_seeds_no_worse():
    default = {
        "n4sid": {"wall": [1.0, 2.0, 3.0], "cpu": [2.0, 2.0, 9.0], "err": [0.1, 0.2, 0.3]},
        "hermite": {"wall": [0.5, 0.6, 9.0], "cpu": [0.5, 1.0, 1.0], "err": [0.1, 0.3, 0.2]},
    }
    line = U._ratio_line("hermite", default)
    # medians 0.6 / 2.0 and 1.0 / 2.0; errors no larger on seeds 0 (equal) and 2
    assert line.startswith("HD-PBSID / N4SID, default environment: wall 0.30x, CPU 0.50x")
    assert line.endswith("no larger than N4SID's on 2 of 3 seeds")
