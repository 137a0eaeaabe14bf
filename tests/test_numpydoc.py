"""The numpydoc sections of the public API, and the examples in its docstrings.

:data:`COMPLETE` names both packages (``bench/complexity.py`` counts the same rule).
For every public function, class and method of a complete package the static
rule of ``bench/docstrings.py`` holds: a summary; ``Parameters`` naming every parameter
of the signature and nothing else; ``Returns`` when a value is returned; ``Raises``
naming the ``ValueError``/``TypeError`` the body raises; a class's constructor
arguments under ``Parameters`` or ``Attributes``; every entry described on its own
indented lines.  The user-facing names of those
packages (exported by ``hdpbsid``) carry ``Examples``, and every ``>>>`` example of a
complete package runs and prints what it says (``doctest``).
"""

from __future__ import annotations

import ast
import doctest
import importlib
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "bench"))

import docstrings  # noqa: E402

#: the packages whose public objects all have their numpydoc sections: both, whole
COMPLETE = ["hdpbsid", "slbasis"]

#: user-facing names (exported by ``hdpbsid`` or shown on the user pages) of the complete
#: packages: each has a runnable ``Examples`` section
WITH_EXAMPLES = {
    "hdpbsid.identify": ["identify"],
    "hdpbsid.models.model": [
        "StateSpaceModel",
        "StateSpaceModel.simulate",
        "StateSpaceModel.fit",
        "StateSpaceModel.predict",
        "StateSpaceModel.compare",
        "StateSpaceModel.residuals",
        "StateSpaceModel.frequency_response",
        "StateSpaceModel.to_discrete",
        "StateSpaceModel.save",
        "DiscreteModel",
    ],
    "hdpbsid.models.model_io": ["save_model", "load_model"],
    "hdpbsid.models.conversion": ["c2d", "d2c"],
    "hdpbsid.models.metrics": ["match_eigenvalues", "eigenvalue_errors"],
    "hdpbsid.models.assessment": ["fit_percent", "residual_tests"],
    "hdpbsid.models.uncertainty": ["response_band"],
    "hdpbsid.data.io": ["read_columns", "read_record", "open_chunked"],
    "hdpbsid.data.records": ["as_records", "split_windows"],
    "hdpbsid.data.detrend": ["detrend_record"],
    "hdpbsid.data.chunked": ["ChunkedRecord"],
    "hdpbsid.frequency.fit": ["frf_welch", "frf_periodic", "identify_frequency"],
    "hdpbsid.frequency.delay": ["delay_from_frf", "estimate_delay"],
    "hdpbsid.design.inputs": [
        "crest_factor",
        "random_binary",
        "prbs",
        "multisine",
        "chirp",
        "hermite_sweep",
        "schroeder_phases",
        "reduce_crest_factor",
    ],
    "hdpbsid.systems.quadrotor": ["pitch_model", "simulate_pitch_closed_loop"],
    "hdpbsid.systems.linear": ["second_order", "simulate_zoh", "add_noise", "random_steps"],
    "hdpbsid.core.pbsid": ["pbsid_core"],
    "hdpbsid.core.varx": ["LagOperator", "SampleShift", "MatrixLag", "varx"],
    "hdpbsid.bases.settings": ["BasisSettings"],
    "hdpbsid.bases.hermite_family": ["HermiteFamily", "hermite_lag"],
    "hdpbsid.bases.sl_family": ["SturmLiouvilleFamily", "integration_matrix"],
    "hdpbsid.bases.basis_domain": ["project_record", "bandwidth", "shared_basis"],
    "hdpbsid.methods.hermite": ["identify_hermite"],
    "hdpbsid.methods.laguerre": ["identify_laguerre", "cayley", "inverse_cayley"],
    "hdpbsid.methods.sturm_liouville": ["identify_sl", "identify_legendre"],
    "hdpbsid.methods.dt": ["identify_discrete", "identify_dt"],
    "hdpbsid.methods.chunked": ["identify_chunked"],
    "hdpbsid.methods.registry": [
        "register_method",
        "get_method",
        "is_available",
        "available_methods",
    ],
    "hdpbsid.cli": ["main", "build_parser"],
    "slbasis.bases": ["basis", "kernel"],
    "slbasis.numeric.basis": [
        "Basis",
        "Basis.project",
        "Basis.reconstruct",
        "Basis.derivative_matrix",
        "Basis.quadrature",
    ],
    "slbasis.symbolic.problem": [
        "SturmLiouville.eigenvalue",
        "SturmLiouville.polynomial",
        "SturmLiouville.norm2",
        "SturmLiouville.recurrence",
        "SturmLiouville.derivative_operator",
        "SturmLiouville.verify",
    ],
}


def _modules(entry: str) -> list[str]:
    path = ROOT / entry
    files = sorted(path.rglob("*.py")) if path.is_dir() else [path]
    out = []
    for f in files:
        if f.name == "__main__.py":  # a command (it runs when imported), no API
            continue
        parts = list(f.relative_to(ROOT).with_suffix("").parts)
        out.append(".".join(parts[:-1] if parts[-1] == "__init__" else parts))
    return out


@pytest.mark.parametrize("entry", COMPLETE)
def test_every_public_object_has_its_numpydoc_sections(entry: str) -> None:
    gaps = docstrings.package_gaps([ROOT / entry], ROOT)
    assert not gaps, "\n".join(f"{g.module}.{g.name}: {'; '.join(g.missing)}" for g in gaps)


def _object(module: str, qualname: str) -> object:
    obj: object = importlib.import_module(module)
    for part in qualname.split("."):
        obj = getattr(obj, part)
    return obj


@pytest.mark.parametrize(
    "module, name", [(m, n) for m, names in WITH_EXAMPLES.items() for n in names]
)
def test_user_facing_objects_have_examples(module: str, name: str) -> None:
    doc = _object(module, name).__doc__ or ""
    assert "Examples\n" in doc and ">>>" in doc, f"{module}.{name}: no Examples section"


@pytest.mark.parametrize("module", [m for e in COMPLETE for m in _modules(e)])
def test_docstring_examples_run(module: str, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("OPENBLAS_NUM_THREADS", "1")
    result = doctest.testmod(
        importlib.import_module(module),
        optionflags=doctest.NORMALIZE_WHITESPACE | doctest.ELLIPSIS,
        verbose=False,
    )
    assert result.failed == 0, f"{module}: {result.failed} of {result.attempted} failed"


# ----- the rule itself: it finds what is missing and accepts what is complete ------------
_GOOD = '''
def f(x: int, *, name: str = "x") -> int:
    """Twice ``x``.

    Parameters
    ----------
    x : int
        A number.
    name : str, optional
        Its name in messages.

    Returns
    -------
    int
        ``2 x``.

    Raises
    ------
    ValueError
        If ``x`` is negative.
    """
    if x < 0:
        raise ValueError(name)
    return 2 * x
'''


def _gaps(source: str) -> list[tuple[str, tuple[str, ...]]]:
    return [(g.name, g.missing) for g in docstrings.module_gaps(ast.parse(source), "m")]


def test_the_rule_accepts_a_complete_docstring() -> None:
    assert _gaps(_GOOD) == []


def test_the_rule_reports_each_missing_section() -> None:
    no_raises = _GOOD.replace("    Raises\n    ------\n    ValueError\n", "    Notes\n    -----\n")
    assert _gaps(no_raises) == [("f", ("Raises: ValueError",))]
    no_returns = _GOOD.replace("Returns\n    -------", "Notes\n    -----")
    assert _gaps(no_returns) == [("f", ("Returns",))]
    renamed = _GOOD.replace("    name : str", "    label : str")
    assert _gaps(renamed) == [("f", ("Parameters: name", "Parameters not in the signature: label"))]
    assert _gaps("def g(a):\n    return a\n") == [("g", ("docstring",))]
    one_line = _GOOD.replace("    x : int\n        A number.\n", "    x : a number.\n")
    assert _gaps(one_line) == [("f", ("no description: x",))]


def test_the_rule_checks_classes_and_their_public_methods_only() -> None:
    source = '''
from dataclasses import dataclass

@dataclass
class P:
    """A point.

    Attributes
    ----------
    x : float
        Abscissa.
    """

    x: float
    y: float

    def norm(self) -> float:
        """Its length."""
        return (self.x**2 + self.y**2) ** 0.5

    def _hidden(self, z):
        return z

class _Private:
    def method(self, a):
        return a
'''
    assert _gaps(source) == [("P", ("Parameters/Attributes: y",)), ("P.norm", ("Returns",))]


def test_public_means_in_all_when_the_module_has_one() -> None:
    assert _gaps('__all__ = ["a"]\ndef a():\n    """A."""\ndef b(x):\n    return x\n') == []
