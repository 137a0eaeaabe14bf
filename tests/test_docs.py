"""The documentation's checkable claims, without building the site (seconds, not minutes).

* every ``>>>`` example of the pages in ``docs/`` runs and prints what the page says
  (``doctest`` on the Markdown sources: the getting-started example identifies a simulated
  system, the user guide's symbols example, the theory page's check of the band formula
  of eq. (11) against ``SturmLiouville.derivative_operator``);
* the architecture page draws the package tree as it is: every module it names exists and
  every module of ``slbasis``/``hdpbsid`` is on it;
* the import directions it states hold (parsed from the sources, not imported);
* the API page names objects that exist.

``make docs`` builds the whole site with warnings as errors.
"""

from __future__ import annotations

import ast
import doctest
import importlib
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
#: the docs pages with examples, and the README (its first-screen example)
PAGES = sorted(p for p in DOCS.glob("*.md") if ">>>" in p.read_text(encoding="utf-8")) + [
    ROOT / "README.md"
]


def test_pages_with_examples_exist() -> None:
    names = {p.name for p in PAGES}
    assert {"getting-started.md", "user-guide.md", "theory.md", "README.md"} <= names


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.name)
def test_doc_examples_run(page: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("OPENBLAS_NUM_THREADS", "1")
    result = doctest.testfile(
        str(page),
        module_relative=False,
        optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE,
        raise_on_error=False,
        verbose=False,
    )
    assert result.attempted > 0, f"{page.name}: no examples found"
    assert result.failed == 0, f"{page.name}: {result.failed} of {result.attempted} failed"


@pytest.mark.parametrize(
    "module", ["slbasis.symbolic.problem", "slbasis.families", "hdpbsid.bases.settings"]
)
def test_docstring_examples_of_the_api_pages_run(module: str) -> None:
    """The ``Examples`` of the docstrings the API reference shows (doctest)."""
    result = doctest.testmod(
        importlib.import_module(module), optionflags=doctest.NORMALIZE_WHITESPACE, verbose=False
    )
    assert result.attempted > 0 and result.failed == 0, result


# ----- the architecture page ---------------------------------------------------------------
_TREE_LINE = re.compile(r"^(?P<indent>(?:[│ ] {3})*)(?:├── |└── )?(?P<name>[\w*.]+/?)")


def _tree_paths() -> set[str]:
    """Paths drawn in the first ``text`` block of architecture.md (``kernels/*.py`` kept)."""
    text = (DOCS / "architecture.md").read_text(encoding="utf-8")
    block = text.split("```text\n", 1)[1].split("```", 1)[0]
    paths: set[str] = set()
    stack: list[str] = []
    for line in block.splitlines():
        if not line.strip():
            stack = []
            continue
        match = _TREE_LINE.match(line)
        assert match, f"architecture.md: cannot read tree line {line!r}"
        name = match.group("name")
        if not line.startswith(("│", " ", "├", "└")):  # a package root, e.g. "slbasis/"
            stack = [name.rstrip("/")]
            continue
        depth = len(match.group("indent")) // 4 + 1
        stack = stack[:depth]
        path = "/".join([*stack, name.rstrip("/")])
        if name.endswith("/"):
            stack.append(name.rstrip("/"))
        else:
            paths.add(path)
    return paths


def _modules() -> set[str]:
    found = set()
    for pkg in ("slbasis", "hdpbsid"):
        for f in (ROOT / pkg).rglob("*.py"):
            rel = f.relative_to(ROOT).as_posix()
            if f.name == "__init__.py" and f.parent != ROOT / pkg:
                continue  # the page says every package directory has one
            if f.parent.name == "kernels" and f.name not in {"__init__.py", "__main__.py"}:
                rel = f"{f.parent.relative_to(ROOT).as_posix()}/*.py"  # generated, one per family
            found.add(rel)
    return found


def test_architecture_tree_is_the_package_tree() -> None:
    drawn, actual = _tree_paths(), _modules()
    missing = sorted(actual - drawn)
    stale = sorted(drawn - actual)
    assert not missing, f"docs/architecture.md: add these modules to the tree: {missing}"
    assert not stale, f"docs/architecture.md: these modules no longer exist: {stale}"


# hdpbsid layers as the architecture page draws them: a module may import its own layer and
# the layers listed for it.
_LAYER_OF = {
    "identify": "front",
    "selection": "front",
    "scaling": "front",
    "io": "front",
    "cli": "front",
    "plots": "front",
    "inputs": "front",
    "frequency_cli": "front",
    "frequency": "methods",
    "studies": "front",
    "__init__": "front",
    "__main__": "front",
    "methods": "methods",
    "core": "core",
    "model": "foundations",
    "model_io": "foundations",
    "conversion": "foundations",
    "checks": "foundations",
    "metrics": "foundations",
    "criteria": "foundations",
    "assessment": "foundations",
    "detrend": "foundations",
    "records": "foundations",
    "recursion": "foundations",
    "recursion_kernels": "foundations",
    "feedback": "foundations",
    "runtime": "foundations",
    "systems": "systems",
}
_MAY_IMPORT = {
    "front": {"front", "methods", "core", "foundations", "systems"},
    "methods": {"methods", "core", "foundations"},
    "core": {"core", "foundations"},
    "foundations": {"foundations"},
    "systems": {"systems", "foundations"},
}


def _internal_imports(path: Path, package: str) -> set[str]:
    """Dotted names of the ``slbasis``/``hdpbsid`` modules ``path`` imports (statically)."""
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
        here = parts
    else:
        here = parts[:-1]
    out = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = here[: len(here) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            names = [target] + [f"{target}.{a.name}" for a in node.names]
        elif isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        else:
            continue
        out.update(n for n in names if n.split(".")[0] in {"slbasis", "hdpbsid"})
    return out


def _layer(dotted: str) -> str | None:
    parts = dotted.split(".")
    return _LAYER_OF.get(parts[1]) if len(parts) > 1 else "front"


def test_hdpbsid_imports_follow_the_layers() -> None:
    bad = []
    for f in sorted((ROOT / "hdpbsid").rglob("*.py")):
        src = _layer("hdpbsid." + ".".join(f.relative_to(ROOT / "hdpbsid").with_suffix("").parts))
        assert src is not None, f"{f}: not on the architecture page's layer list"
        for target in _internal_imports(f, "hdpbsid"):
            if not target.startswith("hdpbsid"):
                continue
            layer = _layer(target)
            if layer is not None and layer not in _MAY_IMPORT[src]:
                bad.append(f"{f.relative_to(ROOT)} ({src}) imports {target} ({layer})")
    assert not bad, "\n".join(bad)


def test_slbasis_imports_follow_the_pipeline() -> None:
    bad = []
    for f in sorted((ROOT / "slbasis").rglob("*.py")):
        rel = f.relative_to(ROOT / "slbasis").parts
        for target in _internal_imports(f, "slbasis"):
            if target.startswith("hdpbsid"):
                bad.append(f"{f}: slbasis never imports hdpbsid ({target})")
            sub = target.split(".")[1] if target.count(".") else ""
            if rel[0] == "numeric" and sub in {"symbolic", "codegen", "families", "bases"}:
                bad.append(f"{f}: numeric never imports {target}")
            upward = {"numeric", "codegen", "families", "bases", "kernels"}
            if rel[0] == "symbolic" and sub in upward:
                bad.append(f"{f}: symbolic imports only itself ({target})")
    assert not bad, "\n".join(bad)


# ----- the API page ------------------------------------------------------------------------
def _api_names() -> list[str]:
    text = (DOCS / "api" / "index.rst").read_text(encoding="utf-8")
    names, module = [], None
    for line in text.splitlines():
        if line.startswith(".. currentmodule::"):
            module = line.split("::", 1)[1].strip()
        elif re.fullmatch(r"   [A-Za-z_][\w.]*", line) and module:
            names.append(f"{module}.{line.strip()}")
    return names


def test_api_page_names_exist() -> None:
    names = _api_names()
    assert len(names) > 20  # the page lists ~35 objects: the parser found them
    for name in names:
        module, _, attr = name.rpartition(".")
        while module:
            try:
                obj = importlib.import_module(module)
                break
            except ModuleNotFoundError:
                module, _, head = module.rpartition(".")
                attr = f"{head}.{attr}"
        for part in attr.split("."):
            obj = getattr(obj, part)
        assert obj.__doc__, f"{name} has no docstring"
