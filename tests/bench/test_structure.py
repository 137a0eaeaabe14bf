"""The structure limits of ``hdpbsid`` hold, measured as ``bench/complexity.py`` measures
them (radon's cyclomatic complexity and source lines, the import graph, the module-level
assignments and the ``options`` reads, from the sources; nothing is imported).

A function above the limits, a long module, an import cycle, a numeric module constant
or a stage that reads its decisions from ``model.options`` fails here with its name."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

BENCH = Path(__file__).resolve().parents[2] / "bench"
sys.path.insert(0, str(BENCH))

import complexity  # noqa: E402  (radon, a test dependency, measures the code)


@pytest.fixture(scope="module")
def report():
    return complexity.measure("hdpbsid")


def test_no_function_above_the_complexity_or_length_limit(report) -> None:
    assert complexity.over_limits(report) == []


def test_no_module_above_the_source_line_limit(report) -> None:
    limit = complexity.MAX_MODULE_LINES
    assert {m: n for m, n in report.module_sloc.items() if n > limit} == {}


def test_no_import_cycle_and_no_module_pair_importing_each_other(report) -> None:
    assert report.cycles == [] and report.mutual_pairs == []


def test_numbers_are_fields_of_settings_not_module_constants(report) -> None:
    assert report.constants == []


def test_no_library_code_reads_model_options(report) -> None:
    assert dict(report.option_reads) == {}
