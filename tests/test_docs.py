"""The documentation's checkable claims, without building the site (seconds, not minutes).

* every ``>>>`` example of the pages in ``docs/`` runs and prints what the page says
  (``doctest`` on the Markdown sources: the getting-started example identifies a simulated
  system, the user guide's symbols example, the theory page's check of the band formula
  of eq. (11) against ``SturmLiouville.derivative_operator``);
* the architecture page draws the package tree as it is: every module it names exists and
  every module of ``slbasis``/``hdpbsid`` is on it;
* the import directions it states hold (parsed from the sources, not imported);
* the API page names objects that exist;
* the README is a user's page: at most 150 lines, the set-up commands first, a ``pip
  install`` route; neither it nor a page of the site (the bench result pages included)
  names a commit: development history belongs to the repository, not to the documents.

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


def _layers() -> list[tuple[str, list[str]]]:
    """The import layers of hdpbsid drawn on the architecture page, top first:
    ``(layer, [entries])`` with entries such as ``identify.py`` or ``methods/``."""
    text = (DOCS / "architecture.md").read_text(encoding="utf-8")
    blocks = [b.split("```", 1)[0] for b in text.split("```text\n")[1:]]
    (block,) = [b for b in blocks if b.strip().splitlines()[-1].startswith("foundations")]
    out = []
    for line in block.strip().splitlines():
        name, entries = re.split(r"\s{2,}", line.strip(), maxsplit=1)
        out.append((name, entries.split()))
    return out


def _rank_of() -> dict[str, int]:
    """Top-level entry of hdpbsid (``identify``, ``methods``, ...) -> its layer's rank
    (0 the lowest)."""
    layers = _layers()
    return {
        entry.removesuffix("/").removesuffix(".py"): len(layers) - 1 - i
        for i, (_, entries) in enumerate(layers)
        for entry in entries
    }


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _runtime_nodes(tree: ast.AST):
    """``ast.walk`` without the bodies of ``if TYPE_CHECKING:`` (never executed)."""
    todo = [tree]
    while todo:
        node = todo.pop()
        yield node
        if isinstance(node, ast.If) and ast.unparse(node.test).endswith("TYPE_CHECKING"):
            todo.extend(node.orelse)
            continue
        todo.extend(ast.iter_child_nodes(node))


def _import_graph(package: str) -> dict[str, set[str]]:
    """Module -> the modules of ``package`` it imports, anywhere in its body (a lazy
    import defers the load, not the dependency); ``from pkg import name`` is the
    submodule ``pkg.name`` when there is one, else ``pkg``."""
    files = {_module_name(f): f for f in (ROOT / package).rglob("*.py")}
    graph = {}
    for name, f in files.items():
        here = name.split(".") if f.name == "__init__.py" else name.split(".")[:-1]
        out = set()
        for node in _runtime_nodes(ast.parse(f.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom):
                base = here[: len(here) - node.level + 1] if node.level else []
                target = ".".join(base + ([node.module] if node.module else []))
                for alias in node.names:
                    sub = f"{target}.{alias.name}"
                    out.add(sub if sub in files else target)
            elif isinstance(node, ast.Import):
                out.update(a.name for a in node.names)
        graph[name] = {t for t in out if t in files and t != name}
    return graph


def test_architecture_layers_name_every_part_of_hdpbsid() -> None:
    drawn = set(_rank_of())
    actual = {p.stem if p.is_file() else p.name for p in (ROOT / "hdpbsid").iterdir()}
    actual = {a for a in actual if not a.startswith((".", "_")) or a.startswith("__i")}
    actual = {a for a in actual if a != "__pycache__"} | {"__main__"}
    assert not actual - drawn, f"architecture.md: add to a layer: {sorted(actual - drawn)}"
    assert not drawn - actual, f"architecture.md: no such module: {sorted(drawn - actual)}"


def test_hdpbsid_imports_follow_the_layers() -> None:
    rank = _rank_of()

    def rank_of(module: str) -> int:
        parts = module.split(".")
        return rank["__init__" if len(parts) == 1 else parts[1]]

    bad = [
        f"{src} (layer {rank_of(src)}) imports {dst} (layer {rank_of(dst)})"
        for src, targets in sorted(_import_graph("hdpbsid").items())
        for dst in sorted(targets)
        if rank_of(dst) > rank_of(src)
    ]
    assert not bad, "imports against the layer order of architecture.md:\n" + "\n".join(bad)


@pytest.mark.parametrize("package", ["hdpbsid", "slbasis"])
def test_no_two_modules_import_each_other(package: str) -> None:
    """No import cycle between any two modules, directly or through others."""
    graph = _import_graph(package)

    def reach(start: str) -> set[str]:
        seen, todo = set(), [start]
        while todo:
            for nxt in graph[todo.pop()] - seen:
                seen.add(nxt)
                todo.append(nxt)
        return seen

    reachable = {m: reach(m) for m in graph}
    cycles = sorted(
        f"{a} <-> {b}" for a in graph for b in reachable[a] if a < b and a in reachable[b]
    )
    assert not cycles, "modules that import each other:\n" + "\n".join(cycles)


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


#: a commit's abbreviated or full hash: 7-40 lower-case hex digits with a letter and a
#: digit, not part of a longer word, a path, a number or a colour (``#1f77b4``)
COMMIT = re.compile(
    r"(?<![0-9A-Za-z_#./-])(?=[0-9a-f]*[a-f])(?=[0-9a-f]*[0-9])[0-9a-f]{7,40}(?![0-9A-Za-z_])"
)


def _user_documents() -> list[Path]:
    """The README, the changelog, the site's Markdown sources and the bench result pages
    the site includes."""
    pages = [p for p in DOCS.rglob("*.md") if "_build" not in p.parts]
    results = sorted((ROOT / "bench" / "results").glob("*.md"))
    return [ROOT / "README.md", ROOT / "CHANGELOG.md", *sorted(pages), *results]


def test_the_commit_pattern_finds_hashes_and_spares_words() -> None:
    hits = COMMIT.findall("at dda43c9: fixed in 410bf2f; colour #1f77b4, add 1234567, decade")
    assert hits == ["dda43c9", "410bf2f"]


def test_no_document_names_a_commit() -> None:
    found = [
        f"{p.relative_to(ROOT)}:{i}: {m.group()}"
        for p in _user_documents()
        for i, line in enumerate(p.read_text(encoding="utf-8").splitlines(), 1)
        for m in COMMIT.finditer(line)
    ]
    assert not found, found


def test_readme_is_a_short_page_that_starts_with_the_commands() -> None:
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    lines = text.splitlines()
    assert len(lines) <= 150
    first_block = text.split("```")[1]
    assert "make demo" in first_block and "make test" in first_block
    assert "pip install ." in text
