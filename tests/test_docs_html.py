"""The built documentation works offline and shows its figures (``docs/check_site.py``).

The checker runs at the end of ``make docs``; here it is tested on small pages written
for the purpose (each defect it must catch, and a page without any), and, where the site
has been built (``.ci/run`` builds it before the tests), on the site itself.
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
SITE = ROOT / "docs" / "_build" / "html"
_spec = importlib.util.spec_from_file_location("check_site", ROOT / "docs" / "check_site.py")
check_site = importlib.util.module_from_spec(_spec)
sys.modules["check_site"] = check_site  # dataclasses look their module up there
_spec.loader.exec_module(check_site)

NAV = '<nav class="bd-docs-nav bd-links"><ul><li><a href="index.html">Home</a></li></ul></nav>'
MATH = '<p><span class="math notranslate nohighlight">\\(\\dot x = A x\\)</span></p>'
LOCAL_MATHJAX = '<script defer="defer" src="_static/mathjax/tex-chtml.js"></script>'


def _site(tmp_path: Path, pages: dict[str, str], mathjax: bool = True) -> Path:
    root = tmp_path / "html"
    (root / "_static" / "mathjax").mkdir(parents=True)
    if mathjax:
        (root / "_static" / "mathjax" / "tex-chtml.js").write_text("/* MathJax */")
    (root / "_static" / "fig.png").write_bytes(b"\x89PNG\r\n\x1a\n")
    for name, body in pages.items():
        path = root / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(f"<html><head>{body[0]}</head><body>{body[1]}</body></html>")
    return root


def test_a_good_page_passes(tmp_path: Path) -> None:
    root = _site(tmp_path, {"index.html": (LOCAL_MATHJAX, NAV + MATH)})
    assert check_site.check_site(root) == []


def test_mathematics_from_a_cdn_is_a_defect(tmp_path: Path) -> None:
    cdn = '<script src="https://cdn.jsdelivr.net/npm/mathjax@3/es5/tex-mml-chtml.js"></script>'
    root = _site(tmp_path, {"theory.html": (cdn, NAV + MATH)})
    problems = check_site.check_site(root)
    assert any("from another host" in p for p in problems)
    assert any("does not load _static/mathjax/tex-chtml.js" in p for p in problems)


def test_local_mathjax_missing_from_the_build_is_a_defect(tmp_path: Path) -> None:
    root = _site(tmp_path, {"theory.html": (LOCAL_MATHJAX, NAV + MATH)}, mathjax=False)
    assert check_site.check_site(root) == [
        "theory.html: _static/mathjax/tex-chtml.js is missing from the build"
    ]


def test_missing_image_and_empty_navigation_are_defects(tmp_path: Path) -> None:
    body = '<img src="_static/fig.png"/><img src="_images/gone.png"/>'
    root = _site(tmp_path, {"page.html": ("", '<nav class="bd-docs-nav"></nav>' + body)})
    assert sorted(check_site.check_site(root)) == [
        "page.html: image _images/gone.png is missing from the build",
        "page.html: the left navigation is empty",
    ]


def test_figures_required_on_notebooks_and_user_guide_sections(tmp_path: Path) -> None:
    img = '<img src="../_static/fig.png"/>'
    guide = (
        NAV.replace('href="', 'href="../')
        + '<section id="guide"><h1>User guide</h1>'
        + '<section id="shown"><h2>Shown</h2><section id="sub"><h3>Sub</h3>'
        + img.replace("../", "")
        + "</section></section>"
        + '<section id="bare"><h2>Bare</h2><p>text only</p></section></section>'
    )
    root = _site(
        tmp_path,
        {
            "user-guide.html": ("", guide),
            "notebooks/01_ok.html": ("", NAV + img),
            "notebooks/02_bare.html": ("", NAV + "<p>no figure</p>"),
        },
    )
    assert sorted(check_site.check_site(root)) == [
        "notebooks/02_bare.html: a notebook page without a figure",
        "user-guide.html: section #bare has no figure",
    ]


@pytest.mark.skipif(not (SITE / "index.html").is_file(), reason="site not built (make docs)")
def test_the_built_site() -> None:
    assert check_site.check_site(SITE) == []
    # the mathematics of the theory page is rendered by the MathJax of the build
    theory = (SITE / "theory.html").read_text(encoding="utf-8")
    assert 'class="math' in theory and "_static/mathjax/tex-chtml.js" in theory
    assert len(list((SITE / "notebooks").glob("*.html"))) >= 4
