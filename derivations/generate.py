"""Regenerate the derivation reports in this folder, one per catalogue family.

    python derivations/generate.py          # or: make derivations

Each report is ``slbasis derive --family NAME`` (Markdown), with symbolic parameters; a test
(``tests/slbasis/test_derivations.py``) regenerates them and fails when a committed one is stale.
"""

from __future__ import annotations

import sys
from pathlib import Path

from slbasis import SturmLiouville
from slbasis.families import families

HERE = Path(__file__).resolve().parent

#: Catalogue entries and the parameter values their reports use (None = symbolic).
REPORTS: dict[str, dict[str, object]] = {
    "hermite": {},
    "hermite_functions": {},
    "laguerre": {},
    "laguerre_functions": {"alpha": 0},
    "legendre": {},
    "chebyshev_t": {},
    "chebyshev_u": {},
    "gegenbauer": {},
    "jacobi": {},
}


def problem(name: str) -> SturmLiouville:
    """The catalogue problem of one entry of :data:`REPORTS`."""
    family = "laguerre" if name == "laguerre_functions" else name
    return families[family](**REPORTS[name])


def report_text(name: str) -> str:
    """The Markdown report for one entry of :data:`REPORTS`."""
    return problem(name).report(fmt="markdown")


def main(argv: list[str] | None = None) -> int:
    names = argv if argv else list(REPORTS)
    for name in names:
        path = HERE / f"{name}.md"
        path.write_text(report_text(name), encoding="utf-8")
        print(f"wrote {path.relative_to(HERE.parent)}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
