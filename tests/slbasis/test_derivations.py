"""Every catalogue family verifies (``verify(nmax=10)``), its committed derivation report is
up to date, and ``slbasis derive`` works."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

from slbasis.cli import main
from slbasis.families import families

ROOT = Path(__file__).resolve().parents[2]
spec = importlib.util.spec_from_file_location("generate", ROOT / "derivations" / "generate.py")
generate = importlib.util.module_from_spec(spec)
spec.loader.exec_module(generate)


@pytest.mark.parametrize("name", sorted(generate.REPORTS))
def test_committed_report_is_current(name: str) -> None:
    # verify(nmax=10) of the family, every kind of check run (a report that skipped them
    # could not fail); the report reads the same verification from the problem's cache,
    # so a family is verified once per test run (symbolic Jacobi takes minutes)
    problem = generate.problem(name)
    verified = problem.verify(nmax=10)
    assert verified.ok, str(verified)
    names = " ".join(c.name for c in verified.checks)
    for needle in ("ODE", "orthogonality", "ladder form == commutator", "sympy's textbook"):
        assert needle in names
    committed = (ROOT / "derivations" / f"{name}.md").read_text(encoding="utf-8")
    assert committed == problem.report(fmt="markdown"), (
        f"derivations/{name}.md is stale: run `make derivations`"
    )
    assert "all checks passed" in committed


def test_every_catalogue_family_has_a_report() -> None:
    # the test above is the catalogue's verification: a family without a report would
    # go unverified
    assert set(families) <= set(generate.REPORTS)


def test_cli_derive_custom_problem(capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["derive", "--p0", "x - x**2", "--p1", "1 - 2*x", "--nmax", "2"])
    out = capsys.readouterr().out
    assert code == 0
    assert "jacobi-like" in out and "all checks passed" in out
    assert "n^{2} + n" in out  # shifted Legendre eigenvalues n(n+1)


def test_cli_latex_and_family_parameters(capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["derive", "--family", "laguerre", "--param", "alpha=1/2", "--format", "latex"])
    out = capsys.readouterr().out
    assert code == 0 and out.startswith(r"\section*{Laguerre")
    assert r"\end{tabular}" in out


def test_cli_bad_input_exit_code(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["derive", "--p0", "x**2", "--p1", "2*x + 2"]) == 2
    assert "Bessel" in capsys.readouterr().err
    assert main(["derive", "--p0", "1"]) == 2
    assert "--p1 is required" in capsys.readouterr().err
