"""Size and structure of a package: the numbers the code's readability is tracked by.

Run: ``python bench/complexity.py [--package hdpbsid] [--out bench/results/complexity.md]
[--list]``.

What is measured (statically, from the sources; nothing is imported):

* **functions** above cyclomatic complexity :data:`MAX_CC` or :data:`MAX_SLOC` source lines
  (``radon``: McCabe's complexity of the function's own branches, nested functions counted
  apart; source lines = radon's ``sloc``, without blank lines, comments and docstrings),
  and the count of blocks of grade C or worse (complexity above 10, radon's ranks);
* **modules** above :data:`MAX_MODULE_LINES` source lines (radon's ``sloc``, as for the
  functions: the numpydoc sections every public object must carry do not count against the
  size of the code a reader has to follow; the physical lines are shown beside them);
* **import cycles** between any two modules of the package: the strongly connected
  components of the graph "module a imports module b" (every ``import`` statement counts,
  also those inside functions: a lazy import defers the load, not the dependency);
  ``from pkg import name`` points at the submodule ``pkg.name`` when it is one, else at
  ``pkg``; a package's ``__init__`` is not implied by importing one of its submodules;
  imports under ``if TYPE_CHECKING:`` (annotations only, never run) do not count;
* **module-level numeric constants**: assignments at module level whose value is a number
  (a literal, a signed one, or arithmetic of literals), dunder names excluded;
* **``options`` keys read** by library code: ``x.options[key]``, ``x.options.get(key)``
  and ``key in x.options`` in a load context (the model's free-form dictionary used as a
  channel between modules);
* **public functions and classes without numpydoc sections**, and public methods of public
  classes without them (the rule of ``bench/docstrings.py``: a summary, ``Parameters``
  naming every parameter, ``Returns`` when a value is returned, ``Raises`` for the
  ``ValueError``/``TypeError`` raised in the body; ``tests/test_numpydoc.py`` holds the
  completed packages to it).

The table is printed and written as Markdown to ``--out``; ``--list`` adds the offending
functions, modules, cycles, constants and keys one per line.  Not a test.
"""

from __future__ import annotations

import argparse
import ast
import textwrap
from collections import Counter, defaultdict
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path

import docstrings
from radon.complexity import cc_visit
from radon.raw import analyze

REPO = Path(__file__).resolve().parent.parent
#: the targets of the code-structure work: a function stays readable below them
MAX_CC = 15
MAX_SLOC = 60
MAX_MODULE_LINES = 500
#: radon's rank C starts above this complexity
GRADE_C = 10


@dataclass
class Report:
    """Everything measured on one package."""

    package: str
    modules: dict[str, int] = field(default_factory=dict)  # dotted name -> physical lines
    module_sloc: dict[str, int] = field(default_factory=dict)  # dotted name -> source lines
    functions: list[tuple[str, str, int, int]] = field(default_factory=list)  # mod, name, cc, sloc
    graded_c: int = 0
    cycles: list[list[str]] = field(default_factory=list)
    mutual_pairs: list[tuple[str, str]] = field(default_factory=list)
    constants: list[tuple[str, str]] = field(default_factory=list)  # module, name
    option_reads: Counter = field(default_factory=Counter)  # key -> reads
    option_sites: dict[str, set[str]] = field(default_factory=lambda: defaultdict(set))
    public: int = 0  # public functions and classes
    public_methods: int = 0  # public methods of public classes
    doc_gaps: list[docstrings.Gap] = field(default_factory=list)


def module_name(path: Path, root: Path) -> str:
    """Dotted module name of ``path`` below ``root`` (``pkg/a/__init__.py`` -> ``pkg.a``)."""
    parts = list(path.relative_to(root).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def imports_of(tree: ast.AST, name: str, is_package: bool, known: set[str]) -> set[str]:
    """Modules of ``known`` that the module ``name`` imports anywhere in its body."""
    here = name.split(".") if is_package else name.split(".")[:-1]
    out: set[str] = set()
    for node in walk_runtime(tree):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = here[: len(here) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            for alias in node.names:
                sub = f"{target}.{alias.name}"
                if sub in known:
                    out.add(sub)
                elif target in known:
                    out.add(target)
        elif isinstance(node, ast.Import):
            out.update(a.name for a in node.names if a.name in known)
    out.discard(name)
    return out


def walk_runtime(tree: ast.AST):
    """``ast.walk`` without the bodies of ``if TYPE_CHECKING:`` (imports for annotations
    only, never executed)."""
    todo = [tree]
    while todo:
        node = todo.pop()
        yield node
        if isinstance(node, ast.If) and ast.unparse(node.test).endswith("TYPE_CHECKING"):
            todo.extend(node.orelse)
            continue
        todo.extend(ast.iter_child_nodes(node))


def strongly_connected(graph: dict[str, set[str]]) -> list[list[str]]:
    """Tarjan's strongly connected components of size above one, each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    out: list[list[str]] = []
    counter = 0

    def visit(v: str) -> None:
        nonlocal counter
        index[v] = low[v] = counter
        counter += 1
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return sorted(out)


def _is_number(node: ast.AST) -> bool:
    if isinstance(node, ast.Constant):
        return isinstance(node.value, int | float | complex) and not isinstance(node.value, bool)
    if isinstance(node, ast.UnaryOp):
        return _is_number(node.operand)
    if isinstance(node, ast.BinOp):
        return _is_number(node.left) and _is_number(node.right)
    return False


def numeric_constants(tree: ast.Module) -> list[str]:
    """Names assigned a number at module level (dunder names excluded)."""
    names = []
    for node in tree.body:
        if isinstance(node, ast.Assign) and _is_number(node.value):
            targets = [t.id for t in node.targets if isinstance(t, ast.Name)]
        elif isinstance(node, ast.AnnAssign) and node.value is not None and _is_number(node.value):
            targets = [node.target.id] if isinstance(node.target, ast.Name) else []
        else:
            continue
        names += [t for t in targets if not (t.startswith("__") and t.endswith("__"))]
    return names


def _is_options(node: ast.AST) -> bool:
    return isinstance(node, ast.Attribute) and node.attr == "options"


def option_reads(tree: ast.AST) -> list[str]:
    """Keys (source text) read from an ``.options`` attribute."""
    keys = []
    for node in ast.walk(tree):
        if (
            isinstance(node, ast.Subscript)
            and isinstance(node.ctx, ast.Load)
            and _is_options(node.value)
        ):
            keys.append(ast.unparse(node.slice))
        elif (
            isinstance(node, ast.Call)
            and isinstance(node.func, ast.Attribute)
            and node.func.attr in {"get", "pop"}
            and _is_options(node.func.value)
            and node.args
        ):
            keys.append(ast.unparse(node.args[0]))
        elif isinstance(node, ast.Compare) and any(
            isinstance(op, ast.In | ast.NotIn) for op in node.ops
        ):
            if any(_is_options(c) for c in node.comparators):
                keys.append(ast.unparse(node.left))
    return keys


def source_lines(lines: list[str]) -> int:
    """radon's ``sloc`` of a function's lines (dedented: a method's body is indented)."""
    return analyze(textwrap.dedent("\n".join(lines)) + "\n").sloc


def _functions(blocks: Iterable) -> Iterable:
    """radon's functions and methods, closures included (classes are counted by methods)."""
    for block in blocks:
        if hasattr(block, "closures"):
            yield block
            yield from _functions(block.closures)


def measure(package: str, root: Path = REPO) -> Report:
    """Measure every module of ``package`` (a directory below ``root``)."""
    report = Report(package)
    files = sorted((root / package).rglob("*.py"))
    names = {module_name(f, root): f for f in files}
    graph: dict[str, set[str]] = {}
    for name, f in names.items():
        text = f.read_text(encoding="utf-8")
        tree = ast.parse(text)
        report.modules[name] = len(text.splitlines())
        report.module_sloc[name] = analyze(text).sloc
        lines = text.splitlines()
        ends = {
            n.lineno: n.end_lineno
            for n in ast.walk(tree)
            if isinstance(n, ast.FunctionDef | ast.AsyncFunctionDef)
        }
        for block in _functions(cc_visit(text)):
            report.graded_c += block.complexity > GRADE_C
            end = ends.get(block.lineno, block.endline)  # radon's endline: last statement's start
            sloc = source_lines(lines[block.lineno - 1 : end])
            label = f"{block.classname}.{block.name}" if block.classname else block.name
            report.functions.append((name, label, block.complexity, sloc))
        graph[name] = imports_of(tree, name, f.name == "__init__.py", set(names))
        report.constants += [(name, c) for c in numeric_constants(tree)]
        for key in option_reads(tree):
            report.option_reads[key] += 1
            report.option_sites[key].add(name)
        top, methods = docstrings.count_public(tree)
        report.public += top
        report.public_methods += methods
        report.doc_gaps += docstrings.module_gaps(tree, name)
    report.cycles = strongly_connected(graph)
    report.mutual_pairs = sorted(
        (a, b) for a in graph for b in graph[a] if a < b and a in graph.get(b, ())
    )
    return report


def over_limits(report: Report) -> list[tuple[str, str, int, int]]:
    """Functions above :data:`MAX_CC` or :data:`MAX_SLOC`, the most complex first."""
    big = [f for f in report.functions if f[2] > MAX_CC or f[3] > MAX_SLOC]
    return sorted(big, key=lambda f: (-f[2], -f[3]))


def summary_rows(report: Report) -> list[tuple[str, str]]:
    big = over_limits(report)
    long_modules = [m for m, n in report.module_sloc.items() if n > MAX_MODULE_LINES]
    in_cycles = sum(len(c) for c in report.cycles)
    return [
        ("modules", f"{len(report.modules)}"),
        ("lines (physical)", f"{sum(report.modules.values())}"),
        ("source lines", f"{sum(report.module_sloc.values())}"),
        ("functions and methods", f"{len(report.functions)}"),
        (f"functions above complexity {MAX_CC} or {MAX_SLOC} source lines", f"{len(big)}"),
        (f"  of them above complexity {MAX_CC}", f"{sum(f[2] > MAX_CC for f in big)}"),
        (f"  of them above {MAX_SLOC} source lines", f"{sum(f[3] > MAX_SLOC for f in big)}"),
        (f"blocks of grade C or worse (complexity > {GRADE_C})", f"{report.graded_c}"),
        ("largest complexity", f"{max((f[2] for f in report.functions), default=0)}"),
        (f"modules above {MAX_MODULE_LINES} source lines", f"{len(long_modules)}"),
        ("largest module (source lines)", f"{max(report.module_sloc.values(), default=0)}"),
        ("import cycles (strongly connected groups)", f"{len(report.cycles)}"),
        ("  modules in a cycle", f"{in_cycles}"),
        ("  pairs importing each other directly", f"{len(report.mutual_pairs)}"),
        ("module-level numeric constants", f"{len(report.constants)}"),
        ("`.options` keys read", f"{len(report.option_reads)}"),
        ("  reads", f"{sum(report.option_reads.values())}"),
        (
            "public functions and classes without numpydoc sections",
            f"{sum(not g.is_method for g in report.doc_gaps)} of {report.public}",
        ),
        (
            "  public methods without numpydoc sections",
            f"{sum(g.is_method for g in report.doc_gaps)} of {report.public_methods}",
        ),
    ]


def _md_table(header: Iterable[str], rows: Iterable[Iterable[object]]) -> list[str]:
    header = list(header)
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    out += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return out


def markdown(report: Report) -> str:
    """The summary and the offenders as a Markdown page."""
    lines = [f"# Code structure of `{report.package}`", "", "Written by `bench/complexity.py`.", ""]
    lines += _md_table(["measure", "value"], summary_rows(report))
    lines += ["", f"## Functions above complexity {MAX_CC} or {MAX_SLOC} source lines", ""]
    lines += _md_table(["module", "function", "complexity", "source lines"], over_limits(report))
    lines += ["", f"## Modules above {MAX_MODULE_LINES} source lines", ""]
    long_modules = sorted(
        ((m, n, report.modules[m]) for m, n in report.module_sloc.items() if n > MAX_MODULE_LINES),
        key=lambda x: -x[1],
    )
    lines += _md_table(["module", "source lines", "physical lines"], long_modules)
    lines += ["", "## Import cycles", ""]
    lines += [f"* {' <-> '.join(c)}" for c in report.cycles] or ["none"]
    lines += ["", "Pairs importing each other directly:", ""]
    lines += [f"* {a} <-> {b}" for a, b in report.mutual_pairs] or ["none"]
    lines += ["", "## Module-level numeric constants per module", ""]
    per_module = Counter(m for m, _ in report.constants)
    lines += _md_table(["module", "constants"], sorted(per_module.items(), key=lambda x: -x[1]))
    lines += ["", "## `.options` keys read by library code", ""]
    rows = [
        (f"`{k}`", n, ", ".join(sorted(report.option_sites[k])))
        for k, n in sorted(report.option_reads.items(), key=lambda x: (-x[1], x[0]))
    ]
    lines += _md_table(["key", "reads", "modules"], rows)
    lines += ["", "## Public functions, classes and methods without numpydoc sections", ""]
    lines += ["(`bench/docstrings.py`: what each docstring lacks)", ""]
    per_module: dict[str, list[str]] = defaultdict(list)
    for gap in report.doc_gaps:
        per_module[gap.module].append(gap.name)
    rows = [(m, len(v), ", ".join(f"`{n}`" for n in v)) for m, v in sorted(per_module.items())]
    lines += _md_table(["module", "count", "objects"], rows)
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--package", default="hdpbsid")
    ap.add_argument("--out", type=Path, default=REPO / "bench" / "results" / "complexity.md")
    ap.add_argument("--list", action="store_true", help="print the offenders too")
    args = ap.parse_args(argv)
    report = measure(args.package)
    width = max(len(k) for k, _ in summary_rows(report))
    for key, value in summary_rows(report):
        print(f"{key:<{width}}  {value:>7}")
    if args.list:
        for mod, name, cc, sloc in over_limits(report):
            print(f"function  {mod}.{name}  cc={cc}  sloc={sloc}")
        for cycle in report.cycles:
            print("cycle     " + " <-> ".join(cycle))
        for key, n in report.option_reads.most_common():
            print(f"option    {key}  {n}")
        for gap in report.doc_gaps:
            print(f"numpydoc  {gap.module}.{gap.name}  lacks {'; '.join(gap.missing)}")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(markdown(report), encoding="utf-8")
    print(f"written: {args.out}")


if __name__ == "__main__":
    main()
