"""Which public functions, classes and methods of a package lack their numpydoc sections.

Static (the sources are parsed, nothing is imported), so that ``bench/complexity.py`` counts
the gaps of the whole package and ``tests/test_numpydoc.py`` holds the packages already
completed to the same rule.

Public: a module-level function or class whose name has no leading underscore and, when the
module has ``__all__``, is in it; and the methods of such a class without a leading
underscore (properties need only a summary line).  The rule, per object:

* a docstring with a one-line summary;
* functions and methods: a ``Parameters`` section naming every parameter of the signature
  (``self``/``cls`` aside; ``*args``/``**kwargs`` by their names) and no parameter the
  signature lacks; a ``Returns`` (or ``Yields``) section when the function returns a value
  (a ``return`` with a value in its own body, a ``yield``, or a return annotation other
  than ``None``); a ``Raises`` section naming ``ValueError``/``TypeError`` when the body
  raises them itself (checks delegated to a helper are not seen: read the code);
* classes: every ``__init__`` parameter, or every field of a dataclass / named tuple,
  named in ``Parameters`` or ``Attributes``;
* every entry of ``Parameters`` / ``Attributes`` has its description on the indented
  lines below ``name : type`` (a one-line ``name : what it is`` puts the description in
  the type's place, where the rendered page shows it as a type).

The sections are read by numpydoc's own parser (``numpydoc.docscrape``), the one the
documentation build uses.
"""

from __future__ import annotations

import ast
import warnings
from dataclasses import dataclass
from pathlib import Path

from numpydoc.docscrape import NumpyDocString

#: exceptions whose direct ``raise`` must be listed under ``Raises`` (bad input, the
#: project's rule: ``ValueError``/``TypeError`` naming the argument)
CHECKED_RAISES = ("ValueError", "TypeError")
_PROPERTY_DECORATORS = {"property", "cached_property", "setter", "deleter", "getter"}


@dataclass(frozen=True)
class Gap:
    """One public object whose docstring lacks something.

    Attributes
    ----------
    module : str
        Dotted module name.
    name : str
        ``function``, ``Class`` or ``Class.method``.
    missing : tuple of str
        What is missing, e.g. ``"Parameters: t, u"``, ``"Returns"``, ``"Raises: ValueError"``.
    """

    module: str
    name: str
    missing: tuple[str, ...]

    @property
    def is_method(self) -> bool:
        """Whether the object is a method (``Class.method``)."""
        return "." in self.name


def public_names(tree: ast.Module) -> set[str] | None:
    """The names of ``__all__`` when the module defines it as a literal, else ``None``."""
    for node in tree.body:
        targets = node.targets if isinstance(node, ast.Assign) else []
        if isinstance(node, ast.AnnAssign):
            targets = [node.target]
        if any(isinstance(t, ast.Name) and t.id == "__all__" for t in targets):
            try:
                return set(ast.literal_eval(node.value))
            except ValueError:
                return None
    return None


def _sections(doc: str) -> NumpyDocString | None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            return NumpyDocString(doc)
        except Exception:  # numpydoc raises plain ValueError/Exception on malformed text
            return None


def _undescribed(parsed: NumpyDocString) -> list[str]:
    return [
        e.name
        for section in ("Parameters", "Other Parameters", "Attributes")
        for e in parsed[section]
        if not any(line.strip() for line in e.desc)
    ]


def _documented(entries) -> set[str]:
    names: set[str] = set()
    for entry in entries:
        for name in entry.name.split(","):
            names.add(name.strip().lstrip("*").strip("`"))
    return names


def _own_nodes(func: ast.AST):
    """The nodes of a function's body, nested functions, lambdas and classes excluded."""
    todo = list(ast.iter_child_nodes(func))
    while todo:
        node = todo.pop()
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.Lambda | ast.ClassDef):
            continue
        yield node
        todo.extend(ast.iter_child_nodes(node))


def _signature(func: ast.FunctionDef | ast.AsyncFunctionDef) -> list[str]:
    a = func.args
    names = [x.arg for x in a.posonlyargs + a.args + a.kwonlyargs]
    names += [x.arg for x in (a.vararg, a.kwarg) if x is not None]
    return [n for n in names if n not in ("self", "cls")]


def _returns_value(func: ast.FunctionDef | ast.AsyncFunctionDef) -> bool:
    if func.returns is not None:
        text = ast.unparse(func.returns)
        if text in ("None", "NoReturn", "typing.NoReturn"):
            return False
        return True
    return any(
        (isinstance(n, ast.Return) and n.value is not None)
        or isinstance(n, ast.Yield | ast.YieldFrom)
        for n in _own_nodes(func)
    )


def _raised(func: ast.AST) -> set[str]:
    out = set()
    for node in _own_nodes(func):
        if isinstance(node, ast.Raise) and node.exc is not None:
            exc = node.exc.func if isinstance(node.exc, ast.Call) else node.exc
            if isinstance(exc, ast.Name) and exc.id in CHECKED_RAISES:
                out.add(exc.id)
    return out


def _is_property(func: ast.FunctionDef | ast.AsyncFunctionDef) -> bool:
    for dec in func.decorator_list:
        name = dec.attr if isinstance(dec, ast.Attribute) else getattr(dec, "id", "")
        if name in _PROPERTY_DECORATORS:
            return True
    return False


def function_gaps(func: ast.FunctionDef | ast.AsyncFunctionDef) -> tuple[str, ...]:
    """What the docstring of ``func`` lacks under the rule of this module."""
    doc = ast.get_docstring(func)
    if not doc or not doc.strip():
        return ("docstring",)
    if _is_property(func):
        return ()
    parsed = _sections(doc)
    if parsed is None:
        return ("unparsable docstring",)
    missing = []
    params = _signature(func)
    documented = _documented(parsed["Parameters"]) | _documented(parsed["Other Parameters"])
    if params:
        lacking = [p for p in params if p not in documented]
        if lacking:
            missing.append("Parameters: " + ", ".join(lacking))
    unknown = sorted(documented - set(params))
    if unknown:
        missing.append("Parameters not in the signature: " + ", ".join(unknown))
    bare = _undescribed(parsed)
    if bare:
        missing.append("no description: " + ", ".join(bare))
    if _returns_value(func) and not (parsed["Returns"] or parsed["Yields"]):
        missing.append("Returns")
    listed = {e.type.strip() for e in parsed["Raises"]} | {e.name for e in parsed["Raises"]}
    for exc in sorted(_raised(func)):
        if not any(exc in entry for entry in listed):
            missing.append(f"Raises: {exc}")
    return tuple(missing)


def _is_dataclass_like(cls: ast.ClassDef) -> bool:
    decorators = {ast.unparse(d).split("(")[0].split(".")[-1] for d in cls.decorator_list}
    bases = {ast.unparse(b).split(".")[-1] for b in cls.bases}
    return "dataclass" in decorators or "NamedTuple" in bases


def class_fields(cls: ast.ClassDef) -> list[str]:
    """The constructor's parameters: ``__init__``'s, else a dataclass's / named tuple's fields."""
    for node in cls.body:
        if isinstance(node, ast.FunctionDef) and node.name == "__init__":
            return [p for p in _signature(node) if not p.startswith("_")]
    if not _is_dataclass_like(cls):
        return []
    fields = []
    for node in cls.body:
        if isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            annotation = ast.unparse(node.annotation)
            if "ClassVar" in annotation or node.target.id.startswith("_"):
                continue
            fields.append(node.target.id)
    return fields


def class_gaps(cls: ast.ClassDef) -> tuple[str, ...]:
    """What the docstring of the class ``cls`` lacks (its methods are checked apart)."""
    doc = ast.get_docstring(cls)
    if not doc or not doc.strip():
        return ("docstring",)
    parsed = _sections(doc)
    if parsed is None:
        return ("unparsable docstring",)
    documented = _documented(parsed["Parameters"]) | _documented(parsed["Attributes"])
    lacking = [f for f in class_fields(cls) if f not in documented]
    missing = ["Parameters/Attributes: " + ", ".join(lacking)] if lacking else []
    bare = _undescribed(parsed)
    if bare:
        missing.append("no description: " + ", ".join(bare))
    return tuple(missing)


def module_gaps(tree: ast.Module, module: str) -> list[Gap]:
    """The gaps of every public function, class and method of one parsed module."""
    names = public_names(tree)
    out = []
    for node in tree.body:
        if node.name.startswith("_") if hasattr(node, "name") else True:
            continue
        if names is not None and node.name not in names:
            continue
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            missing = function_gaps(node)
            if missing:
                out.append(Gap(module, node.name, missing))
        elif isinstance(node, ast.ClassDef):
            missing = class_gaps(node)
            if missing:
                out.append(Gap(module, node.name, missing))
            for item in node.body:
                if isinstance(item, ast.FunctionDef | ast.AsyncFunctionDef):
                    if item.name.startswith("_"):
                        continue
                    missing = function_gaps(item)
                    if missing:
                        out.append(Gap(module, f"{node.name}.{item.name}", missing))
    return out


def count_public(tree: ast.Module) -> tuple[int, int]:
    """Public (functions and classes, methods of public classes) of one module."""
    names = public_names(tree)
    top = methods = 0
    for node in tree.body:
        if not isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
            continue
        if node.name.startswith("_") or (names is not None and node.name not in names):
            continue
        top += 1
        if isinstance(node, ast.ClassDef):
            methods += sum(
                isinstance(i, ast.FunctionDef | ast.AsyncFunctionDef) and not i.name.startswith("_")
                for i in node.body
            )
    return top, methods


def package_gaps(paths: list[Path], root: Path) -> list[Gap]:
    """The gaps of every module in ``paths`` (files or package directories below ``root``)."""
    out = []
    for path in paths:
        files = sorted(path.rglob("*.py")) if path.is_dir() else [path]
        for f in files:
            parts = list(f.relative_to(root).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts = parts[:-1]
            out += module_gaps(ast.parse(f.read_text(encoding="utf-8")), ".".join(parts))
    return out
