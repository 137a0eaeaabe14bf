"""Sphinx configuration of the slbasis + hdpbsid documentation (``make docs``).

The site works offline: MathJax is served from the build (``sphinx-mathjax-offline``),
nothing is loaded from another host (``docs/check_site.py``, run by ``make docs``, checks
the built pages).

Executed pages: the notebooks (jupytext percent scripts ``notebooks/*.py``, copied into
``docs/notebooks/`` at build time) and the MyST notebook pages of this folder (a
``file_format: mystnb`` header) are executed by myst-nb during the build, with
``HDPBSID_NOTEBOOK_SMALL=1`` (the notebooks' small settings), so every page shows its
printed results and figures as the code produces them now.

Benchmark pages: each ``bench/results/<script>.md`` that a benchmark script writes is
included in a page; scripts without a page of their own here get one generated into
``docs/_generated/`` (gitignored), and the regression table is rendered from
``bench/results/regression.csv`` by ``bench/regression.py`` itself.
"""

from __future__ import annotations

import os
import shutil
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

project = "slbasis + hdpbsid"
author = "slbasis-hdpbsid contributors"
copyright = "the slbasis-hdpbsid contributors"  # noqa: A001 - Sphinx's name

extensions = [
    "myst_nb",
    "numpydoc",
    "sphinx-mathjax-offline",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
]

source_suffix = {".rst": "restructuredtext", ".md": "myst-nb", ".py": "myst-nb"}
exclude_patterns = [
    "_build",
    "**.ipynb_checkpoints",
    "conf.py",
    "check_site.py",
    "jupyter_execute",
    # included by the benchmark pages, not pages themselves
    "_generated/regression-table.md",
    "_generated/bench-toc.md",
]
# the notebooks are jupytext percent scripts; myst-nb reads them through jupytext
nb_custom_formats = {".py": ["jupytext.reads", {"fmt": "py:percent"}]}
nb_execution_mode = "force"
nb_execution_timeout = 600
nb_execution_raise_on_error = True
nb_execution_show_tb = True
nb_merge_streams = True
# the notebooks' small settings, inherited by the kernels the build starts; matplotlib's
# inline backend there (a user's MPLBACKEND=Agg would leave the pages without figures)
os.environ["HDPBSID_NOTEBOOK_SMALL"] = "1"
os.environ.pop("MPLBACKEND", None)
os.environ.pop("HDPBSID_NOTEBOOK_FIGDIR", None)
myst_enable_extensions = ["dollarmath", "amsmath", "colon_fence"]
myst_heading_anchors = 3

templates_path = ["_templates"]
autosummary_generate = True
autodoc_typehints = "none"  # numpydoc renders the signature; hints stay in the source
autodoc_member_order = "bysource"
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
# a docstring without sections is valid numpydoc; only fail the build on real errors
numpydoc_validation_checks: set[str] = set()

html_theme = "pydata_sphinx_theme"
html_title = "slbasis + hdpbsid"
html_theme_options = {
    "navigation_with_keys": False,
    "show_toc_level": 2,
    "header_links_before_dropdown": 6,
}
# the whole site's contents on every page (the theme's default shows only the current
# section's pages, which left most pages without a left navigation)
html_sidebars = {"**": ["site-toc.html"]}
html_static_path: list[str] = []

# the rendered notebooks are copies of notebooks/*.py (gitignored, refreshed every build)
_NB_SRC, _NB_DST = ROOT / "notebooks", Path(__file__).resolve().parent / "notebooks"
_NB_DST.mkdir(exist_ok=True)
for _old in _NB_DST.glob("*.py"):
    if not (_NB_SRC / _old.name).exists():
        _old.unlink()
for _src in sorted(_NB_SRC.glob("[0-9]*.py")):
    _dst = _NB_DST / _src.name
    if not _dst.exists() or _dst.read_bytes() != _src.read_bytes():
        shutil.copyfile(_src, _dst)

# -- benchmark pages ----------------------------------------------------------------------
_RESULTS = ROOT / "bench" / "results"
_GEN = Path(__file__).resolve().parent / "_generated"
_GEN.mkdir(exist_ok=True)
#: titles of the generated pages of bench/results/<script>.md without a page of their own
BENCH_TITLES = {
    "user": "Threads, first call and start-up",
    "frequency": "Frequency-domain estimates",
    "long_records": "Long records with the defaults",
    "segments": "Several records and windows",
    "identify": "Accuracy of the methods",
}


def _write_if_changed(path: Path, text: str) -> None:
    if not path.exists() or path.read_text(encoding="utf-8") != text:
        path.write_text(text, encoding="utf-8")


def _bench_pages() -> None:
    """One page per ``bench/results/<script>.md`` that no ``docs/bench-<script>.md``
    includes, and the regression summary rendered from its CSV."""
    own = {p.stem.removeprefix("bench-") for p in Path(__file__).parent.glob("bench-*.md")}
    wanted = set()
    for md in sorted(_RESULTS.glob("*.md")):
        if md.stem in own:
            continue
        title = BENCH_TITLES.get(md.stem, md.stem.replace("_", " ").capitalize())
        page = _GEN / f"bench-{md.stem}.md"
        wanted.add(page.name)
        _write_if_changed(
            page,
            f"# {title}\n\nThe output of `python bench/{md.stem}.py` (its docstring says "
            f"how it measures), as it wrote it to `bench/results/{md.stem}.md`.\n\n"
            f"```{{include}} ../../bench/results/{md.stem}.md\n```\n",
        )
    for old in _GEN.glob("bench-*.md"):
        if old.name not in wanted and old.name != "bench-toc.md":
            old.unlink()
    entries = "".join(f"_generated/{Path(name).stem}\n" for name in sorted(wanted))
    toc = f"```{{toctree}}\n:maxdepth: 1\n\n{entries}```\n" if entries else "\n"
    _write_if_changed(_GEN / "bench-toc.md", toc)
    sys.path.insert(0, str(ROOT / "bench"))
    try:
        import regression  # bench/regression.py: the table's own renderer
    finally:
        sys.path.pop(0)
    rows = regression.read_csv(_RESULTS / "regression.csv")
    _write_if_changed(_GEN / "regression-table.md", regression.summary_text(rows) + "\n")


_bench_pages()
