"""Sphinx configuration of the slbasis + hdpbsid documentation (``make docs``).

Notebooks: the jupytext percent-format sources in ``notebooks/*.py`` are copied into
``docs/notebooks/`` at build time and rendered by myst-nb *without execution*
(``nb_execution_mode = "off"``): they carry no stored outputs, and executing them takes
minutes; ``tests/test_notebooks.py`` executes them in the test suite instead.
"""

from __future__ import annotations

import shutil
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

project = "slbasis + hdpbsid"
author = "slbasis-hdpbsid contributors"
copyright = "the slbasis-hdpbsid contributors"  # noqa: A001 - Sphinx's name

extensions = [
    "myst_nb",
    "numpydoc",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
]

source_suffix = {".rst": "restructuredtext", ".md": "myst-nb", ".py": "myst-nb"}
exclude_patterns = ["_build", "**.ipynb_checkpoints", "conf.py"]
# the notebooks are jupytext percent scripts; myst-nb reads them through jupytext
nb_custom_formats = {".py": ["jupytext.reads", {"fmt": "py:percent"}]}
nb_execution_mode = "off"
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
html_theme_options = {"navigation_with_keys": False, "show_toc_level": 2}
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
