"""hdpbsid.models.report: the typed report beside the model, what it says against what was
decided, old model files, and no stage reading its decisions out of ``model.options``."""

from __future__ import annotations

import ast
import copy
import json
import pickle
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import hdpbsid
from hdpbsid import StateSpaceModel, load_model
from hdpbsid.models.criteria import windowed_simulation_error
from hdpbsid.models.report import (
    Candidate,
    Choice,
    DirectTerm,
    IdentificationReport,
    Refinement,
    WarmStart,
)
from hdpbsid.refine.pem import refine_pem
from hdpbsid.systems.linear import simulate_zoh

ROOT = Path(__file__).resolve().parents[3]

# a lightly damped second-order system (poles -0.5 +- 2.96j), the record's steps held
# 0.5 s: slow against the 0.02 s sampling, so every method resolves it
A2 = np.array([[0.0, 1.0], [-9.0, -1.0]])
B2 = np.array([[0.0], [9.0]])
C2 = np.array([[1.0, 0.0]])
D2 = np.zeros((1, 1))


def _record(seed: int, ns: int = 1500, snr_noise: float = 0.02):
    rng = np.random.default_rng(seed)
    t = np.arange(ns) * 0.02
    u = np.repeat(rng.choice([-1.0, 1.0], size=ns // 25 + 1), 25)[:ns, None]
    y = simulate_zoh(A2, B2, C2, D2, t, u)
    return t, u, y + snr_noise * np.std(y) * rng.standard_normal(y.shape)


# -- the types ------------------------------------------------------------------------


@given(value=st.one_of(st.booleans(), st.text(max_size=12), st.none()))
def test_direct_term_means_what_the_stages_read_from_the_option(value) -> None:
    """The three rules the stages applied to ``options["feedthrough"]`` (a method takes
    ``feedthrough=`` when it reports a boolean; ``D`` is a refinement parameter when
    that boolean is True; the feedback rule's ``bool(option)``) hold for the typed
    direct term made from the same option."""
    term = DirectTerm.from_option(value)
    honours = term is not None and not term.by_method
    asked = term is not None and term.asked
    estimated = term is not None and term.estimated
    assert honours == isinstance(value, bool)
    assert asked == (isinstance(value, bool) and value)
    assert estimated == bool(value)


_cell = st.none() | st.floats(allow_nan=False) | st.integers(0, 9)


@given(
    method=st.sampled_from(["dt", "hermite", "laguerre"]),
    order=st.none() | st.integers(1, 8),
    feedthrough=st.booleans(),
    error=_cell,
    z=_cell,
    status=st.text(max_size=8),
)
def test_a_candidate_round_trips_through_its_row(method, order, feedthrough, error, z, status):
    row = Candidate(method, order, feedthrough, error=error, z=z, status=status).as_dict()
    assert Candidate.from_dict(row).as_dict() == row
    assert list(row)[:3] == ["method", "order", "feedthrough"]


def test_the_repr_is_a_short_summary_without_arrays() -> None:
    big = np.ones((40, 40))
    report = IdentificationReport(
        method="hermite",
        input_hold=Choice("foh", "given"),
        feedthrough=DirectTerm(False, False),
        candidates=tuple(Candidate("hermite", n) for n in range(1, 9)),
        refinement=Refinement(True, 14, "foh", "model K", (1.0, 0.5), np.ones(40)),
        warm_start=WarmStart(big, big[:, :1], big[:1], big[:1, :1], big[:, :1]),
    )
    text = repr(report)
    assert "array" not in text and "1." not in text and len(text) < 200, text
    assert "8 candidates" in text and "input hold foh (given)" in text


def test_a_model_with_its_report_pickles() -> None:
    """The workers of a parallel sweep (joblib) return models with their reports."""
    report = IdentificationReport(
        method="hermite",
        windows={"p": 3},
        refit_settings=Choice({"alpha": "basis"}, "4 * scale"),
        candidates=(Candidate("hermite", 2, status="ok"),),
        refinement=Refinement(True, 9, "zoh", "model K", (1.0, 0.5), np.ones(2)),
        timings={"method": 0.5},
    )
    model = StateSpaceModel(A2, B2, C2, D2, np.zeros((2, 1)), report=report)
    back = pickle.loads(pickle.dumps(model))
    assert back.report.windows == {"p": 3} and back.report.refit_settings == report.refit_settings
    assert back.report.candidates == report.candidates and back.report.timings == report.timings
    np.testing.assert_array_equal(back.report.refinement.eigenvalue_std, np.ones(2))


def test_a_report_is_changed_by_copy_only() -> None:
    model = StateSpaceModel(A2, B2, C2, D2, np.zeros((2, 1)), options={"method": "dt"})
    other = copy.copy(model)
    other.report = other.report.but(method="hermite", warm_start=WarmStart.of(model))
    assert model.report.method == "dt" and model.report.warm_start is None
    with pytest.raises(AttributeError):
        other.report.method = "laguerre"  # frozen
    with pytest.raises(TypeError, match="report must be"):
        StateSpaceModel(A2, B2, C2, D2, np.zeros((2, 1)), report={"method": "dt"})


def test_a_model_without_a_report_reports_its_options_as_they_change() -> None:
    """A user's method that records its choices in ``options`` after building the model
    (the way methods were written before the report): the stages see them."""
    model = StateSpaceModel(A2, B2, C2, D2, np.zeros((2, 1)))
    assert model.report.method is None and model.report.hold is None
    model.options.update(method="mine", input_hold="foh", input_hold_rule="given", p=4)
    assert model.report.method == "mine"
    assert model.report.input_hold == Choice("foh", "given") and model.report.input_hold.given
    assert model.report.windows == {"p": 4}


# -- what was decided -----------------------------------------------------------------


def test_the_report_of_a_given_hold_follows_it_through_the_refinement() -> None:
    """``input_hold="foh"`` given to HD-PBSID: the report says so, and the refinement
    fits only that hold (the method was told it), reporting the hold it fitted."""
    t, u, y = _record(0)
    model = hdpbsid.identify(t, u, y, 2, method="hermite", input_hold="foh", refine=None)
    assert model.report.input_hold == Choice("foh", "given")
    refined = refine_pem(model, t, u, y)
    assert refined.options["refine_holds_tried"] == ("foh",)
    assert refined.report.refinement is not None and refined.report.refinement.hold == "foh"
    assert refined.report.input_hold.given and refined.report.hold == "foh"
    std = refined.report.refinement.eigenvalue_std
    assert std is not None and np.shape(std) == (2,)
    assert model.report.refinement is None  # the start is not changed


def test_the_direct_term_asked_for_is_reported_and_estimated() -> None:
    t, u, y = _record(1)
    with_d = hdpbsid.identify(t, u, y, 2, method="dt", feedthrough=True, refine=None)
    without = hdpbsid.identify(t, u, y, 2, method="dt", feedthrough=False, refine=None)
    assert with_d.report.order == Choice(2, "given") and with_d.report.refine_decision is None
    assert with_d.report.feedthrough == DirectTerm(True, False)
    assert without.report.feedthrough == DirectTerm(False, False)
    assert np.all(without.D == 0.0)  # D = 0 exactly when not asked for
    assert with_d.report.windows["p"] >= 1 and with_d.report.windows["f"] >= 1


def test_the_selection_report_holds_the_one_standard_error_choice() -> None:
    """``method="auto"`` on the second-order record: the chosen method and order are a
    scored candidate of the report within one standard error of the best (the rule of
    :func:`hdpbsid.models.criteria.choose_smallest_adequate`), the true order 2 is
    found (noise 2 % of the output's spread on 1500 samples leaves no doubt), and the
    refinement's warm start is not left in the result."""
    t, u, y = _record(2)
    model = hdpbsid.identify(t, u, y, method="auto", refine="pem", max_order=4)
    report = model.report
    assert model.n == 2 and report.method in {"dt", "hermite", "laguerre", "legendre"}
    mine = [c for c in report.order_candidates() if c.order == model.n]
    assert mine and all(c.method == report.method for c in report.order_candidates())
    scored = [c for c in mine if c.status == "ok" and c.z is not None]
    assert scored and min(c.z for c in scored) <= 1.0
    assert {c.order for c in report.candidates} <= {1, 2, 3, 4}
    assert report.refinement is not None and report.refinement.nfev > 0
    assert report.refine_decision == Choice(True, "pem: asked for")
    assert report.order is not None and report.order.value == 2 and not report.order.given
    assert report.warm_start is None and set(report.timings) == {"method", "refine"}


# -- old model files ------------------------------------------------------------------


def test_an_old_model_file_keeps_its_decisions(tmp_path: Path) -> None:
    """A model file written before the report existed: its options hold the hold, the
    direct term, the windows and the selection table, and the loaded model acts on them
    (its simulation error uses the file's ``foh`` hold, as before)."""
    t, u, y = _record(3, ns=600)
    rows = [
        {"method": "hermite", "order": n, "feedthrough": False, "error": 0.1 * n, "z": n - 2.0}
        for n in (1, 2, 3)
    ]
    options = {
        "method": "hermite",
        "input_hold": "foh",
        "input_hold_rule": "given",
        "feedthrough": True,
        "p": 3,
        "selection": rows,
        "refine": "pem",
        "refine_converged": False,
        "refine_nfev": 400,
        "refine_start": "model K",
        "eigenvalue_std": [0.1, 0.1],
    }
    StateSpaceModel(A2, B2, C2, D2, np.zeros((2, 1)), options=options).save(tmp_path / "m.json")
    raw = json.loads((tmp_path / "m.json").read_text())
    assert "report" not in raw  # the file format is unchanged
    model = load_model(tmp_path / "m.json")
    report = model.report
    assert report.input_hold == Choice("foh", "given") and report.feedthrough.asked
    assert report.windows == {"p": 3} and [c.order for c in report.order_candidates()] == [1, 2, 3]
    assert report.refinement is not None and not report.refinement.converged
    assert report.refinement.nfev == 400 and not report.converged
    err = windowed_simulation_error(model, t, u, y, 4)
    foh = windowed_simulation_error(model, t, u, y, 4, hold="foh")
    zoh = windowed_simulation_error(model, t, u, y, 4, hold="zoh")
    assert err.total == foh.total and err.total != zoh.total


# -- no stage reads its decisions out of model.options --------------------------------

#: the reads of ``.options`` left in the library, each display or serialization
ALLOWED = {
    # the CLI reads the column names and sampling interval it wrote into a model file
    ("hdpbsid/cli.py", "'columns'"),
    ("hdpbsid/cli.py", "'sampling_interval'"),
    # the delay estimate compares frequency-domain fits by the cost they record, and a
    # FrequencyResponse's own options (not a model's)
    ("hdpbsid/frequency/delay.py", "'cost'"),
    ("hdpbsid/frequency/delay.py", "'dt'"),
    # a study reads the Hermite time scale to set its operator scale
    ("hdpbsid/studies/second_order.py", "'scale'"),
}


def _option_reads(tree: ast.AST) -> list[str]:
    """Keys read from an ``.options`` attribute: ``x.options[k]``, ``x.options.get(k)``,
    ``x.options.pop(k)`` and ``k in x.options`` (written apart from the benchmark's
    counter, bench/complexity.py, as a second reading of the same rule)."""

    def is_options(node: ast.AST) -> bool:
        return isinstance(node, ast.Attribute) and node.attr == "options"

    keys = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Subscript) and isinstance(node.ctx, ast.Load):
            if is_options(node.value):
                keys.append(ast.unparse(node.slice))
        elif isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute):
            if node.func.attr in {"get", "pop"} and is_options(node.func.value) and node.args:
                keys.append(ast.unparse(node.args[0]))
        elif isinstance(node, ast.Compare) and any(is_options(c) for c in node.comparators):
            keys.append(ast.unparse(node.left))
    return keys


def test_no_stage_reads_its_decisions_from_the_options() -> None:
    reads = set()
    for path in sorted((ROOT / "hdpbsid").rglob("*.py")):
        rel = path.relative_to(ROOT).as_posix()
        reads |= {(rel, k) for k in _option_reads(ast.parse(path.read_text()))}
    assert reads <= ALLOWED, sorted(reads - ALLOWED)


def test_the_reader_finds_every_form_of_read() -> None:
    src = "a = m.options['x']\nb = m.options.get('y')\nc = 'z' in m.options\nm.options['w'] = 1"
    assert sorted(_option_reads(ast.parse(src))) == ["'x'", "'y'", "'z'"]


@settings(max_examples=20, deadline=None)
@given(name=st.sampled_from(["zoh", "foh"]), reason=st.sampled_from(["given", "auto: AIC"]))
def test_the_hold_of_the_report_is_the_one_simulated(name, reason) -> None:
    """The hold a model reports is the one its simulation error uses by default."""
    t, u, y = _record(4, ns=300)
    model = StateSpaceModel(
        A2,
        B2,
        C2,
        D2,
        np.zeros((2, 1)),
        report=IdentificationReport(input_hold=Choice(name, reason)),
    )
    assert (
        windowed_simulation_error(model, t, u, y, 3).total
        == windowed_simulation_error(model, t, u, y, 3, hold=name).total
    )


def test_a_method_s_own_order_table_becomes_its_candidates() -> None:
    """A method that lists the orders it tried without naming itself in each row (the
    frequency-domain fit) gets a report whose candidates carry its name; the model's
    repr, which reads the report, works."""
    from hdpbsid.frequency import fit as frequency

    w = np.logspace(-1, 1, 60)
    H = (1.0 / ((1j * w) ** 2 + 0.8j * w + 4.0))[None, None, :]
    model = frequency.identify_frequency(w, H)
    rows = model.options["selection"]
    assert rows and all("method" not in r for r in rows)
    assert {c.method for c in model.report.candidates} == {"frequency"}
    assert [c.order for c in model.report.candidates] == [r["order"] for r in rows]
    assert "frequency" in repr(model)


def test_the_basis_a_method_used_is_in_the_report() -> None:
    import slbasis
    from hdpbsid.systems import second_order, simulate_zoh

    report = IdentificationReport.from_options(
        {"N": 120, "scale": 2.5, "alpha": "basis", "p": 3, "feedthrough": True}
    )
    assert report.basis == {"N": 120.0, "scale": 2.5}  # numbers only: "basis" is a rule
    A, B, C, D = second_order()
    t = np.arange(2000) * 0.02
    u = np.sin(0.7 * t) + np.sin(2.3 * t)
    y = simulate_zoh(A, B, C, D, t, u)
    model = hdpbsid.identify(t, u, y, 2, method="hermite", N=150, refine=None, detrend=None)
    # one record, no windows: the basis slbasis builds for N functions on the record
    oracle = slbasis.basis("hermite", 150, (float(t[0]), float(t[-1]))).scale
    assert model.report.basis["N"] == 150 and model.report.basis["scale"] == oracle
    assert hdpbsid.identify(t, u, y, 2, method="dt", refine=None).report.basis == {}


def test_the_report_carries_the_typed_rules_of_alpha_and_the_pole() -> None:
    """The operator scale of a Hermite identification and the pole of a Laguerre one reach
    the report as choices with their policies' enum members (not only their texts), and
    the texts stay the ones ``model.options`` writes."""
    from hdpbsid.bases.laguerre_pole import PoleRule
    from hdpbsid.bases.operator_scale import AlphaRule

    t, u, y = _record(2)
    hermite = hdpbsid.identify(t, u, y, 2, method="hermite", alpha="basis", refine=None)
    alpha = hermite.report.alpha
    assert alpha is not None and alpha.rule is AlphaRule.BASIS
    assert alpha.value == hermite.options["alpha"] and alpha.reason == hermite.options["alpha_rule"]
    chosen = hdpbsid.identify(t, u, y, 2, method="hermite", refine=None).report.alpha
    assert isinstance(chosen.rule, AlphaRule) and chosen.rule is not AlphaRule.BASIS
    given = hdpbsid.identify(t, u, y, 2, method="hermite", alpha=3.0, refine=None).report.alpha
    assert given.rule is AlphaRule.GIVEN and given.given and given == Choice(3.0, "given")
    laguerre = hdpbsid.identify(t, u, y, 2, method="laguerre", refine=None)
    pole = laguerre.report.pole
    assert pole is not None and pole.rule is PoleRule.CONDITIONED
    assert pole.value == laguerre.options["a"] and pole.reason == laguerre.options["a_rule"]
    assert "rule=PoleRule.CONDITIONED" in repr(pole)
    legendre = hdpbsid.identify(t, u, y, 2, method="legendre", alpha=2.0, N=700, refine=None)
    assert legendre.report.alpha.rule is AlphaRule.GIVEN
