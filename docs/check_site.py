"""Check the built site works offline and shows what it should (run by ``make docs``).

``python docs/check_site.py [docs/_build/html]`` exits with status 1 and one line per
problem when

* a page loads a script, style sheet or image from another host (the site must work
  without a network: MathJax is served from ``_static/mathjax``);
* a page with mathematics does not load the local MathJax, or that file is missing;
* an image a page shows is missing from the build;
* a notebook page, or a top-level section of the user guide, has no figure;
* a page's left navigation is empty.

Only the standard library: it runs in any environment the tests run in.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass, field
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import urlparse

#: the MathJax entry point sphinx-mathjax-offline configures, relative to the site root
MATHJAX = "_static/mathjax/tex-chtml.js"
#: pages whose every ``<section>`` of the second level must show a figure
ILLUSTRATED_SECTIONS = ("user-guide.html",)
#: folders whose every page must show a figure
ILLUSTRATED_PAGES = ("notebooks",)


@dataclass
class Page:
    """What :class:`_Reader` collects from one HTML page."""

    scripts: list[str] = field(default_factory=list)
    styles: list[str] = field(default_factory=list)
    images: list[str] = field(default_factory=list)
    has_math: bool = False
    nav_links: int = 0
    #: per second-level section (its id): the number of images in it
    section_images: dict[str, int] = field(default_factory=dict)


class _Reader(HTMLParser):
    def __init__(self) -> None:
        super().__init__(convert_charrefs=True)
        self.page = Page()
        self._nav_depth = 0
        self._sections: list[tuple[str, bool]] = []  # (id, is second level) per open section
        self._pending: str | None = None

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        a = {k: v or "" for k, v in attrs}
        cls = a.get("class", "").split()
        if tag == "script" and a.get("src"):
            self.page.scripts.append(a["src"])
        elif tag == "link" and "stylesheet" in a.get("rel", "").split():
            self.page.styles.append(a.get("href", ""))
        elif tag == "img":
            self.page.images.append(a.get("src", ""))
            for sid, second in self._sections:
                if second:
                    self.page.section_images[sid] += 1
        if "math" in cls or "MathJax" in a.get("class", ""):
            self.page.has_math = True
        if tag == "nav" and "bd-docs-nav" in cls:
            self._nav_depth = 1
        elif self._nav_depth and tag == "nav":
            self._nav_depth += 1
        elif self._nav_depth and tag == "a" and a.get("href"):
            self.page.nav_links += 1
        if tag == "section":
            self._sections.append((a.get("id", ""), False))
            self._pending = a.get("id", "")
        if tag == "h2" and self._sections and self._pending == self._sections[-1][0]:
            sid = self._sections[-1][0]
            self._sections[-1] = (sid, True)
            self.page.section_images[sid] = 0
        if tag in ("h1", "h2", "h3", "h4"):
            self._pending = None

    def handle_endtag(self, tag: str) -> None:
        if tag == "nav" and self._nav_depth:
            self._nav_depth -= 1
        elif tag == "section" and self._sections:
            self._sections.pop()


def read_page(text: str) -> Page:
    """Parse one page (:class:`Page`)."""
    reader = _Reader()
    reader.feed(text)
    return reader.page


def _remote(url: str) -> bool:
    return bool(urlparse(url).netloc) or url.startswith("//")


def check_page(path: Path, root: Path) -> list[str]:
    """The problems of the page at ``path`` of the site built in ``root``."""
    page = read_page(path.read_text(encoding="utf-8"))
    rel = path.relative_to(root).as_posix()
    problems = [
        f"{rel}: loads {u} from another host" for u in page.scripts + page.styles if _remote(u)
    ]
    for src in page.images:
        if _remote(src):
            problems.append(f"{rel}: shows the image {src} from another host")
        elif not src.startswith("data:") and not (path.parent / src.split("#")[0]).is_file():
            problems.append(f"{rel}: image {src} is missing from the build")
    if page.has_math:
        local = [s for s in page.scripts if s.split("?")[0].endswith(MATHJAX)]
        if not local:
            problems.append(f"{rel}: has mathematics but does not load {MATHJAX}")
        elif not (path.parent / local[0].split("?")[0]).is_file():
            problems.append(f"{rel}: {local[0]} is missing from the build")
    if page.nav_links == 0:
        problems.append(f"{rel}: the left navigation is empty")
    if rel in ILLUSTRATED_SECTIONS:
        bare = [sid for sid, n in page.section_images.items() if n == 0]
        problems += [f"{rel}: section #{sid} has no figure" for sid in bare]
    if rel.split("/")[0] in ILLUSTRATED_PAGES and rel.count("/") == 1 and not page.images:
        problems.append(f"{rel}: a notebook page without a figure")
    return problems


def check_site(root: Path) -> list[str]:
    """The problems of every page of the site built in ``root`` (``[]``: none)."""
    pages = [
        p
        for p in sorted(root.rglob("*.html"))
        if not {"_static", "_sources", "_modules"} & set(p.relative_to(root).parts)
        and p.name not in ("search.html", "genindex.html", "py-modindex.html")
    ]
    if not pages:
        return [f"{root}: no pages (build the site first: make docs)"]
    return [problem for p in pages for problem in check_page(p, root)]


def main(argv: list[str] | None = None) -> int:
    args = sys.argv[1:] if argv is None else argv
    root = Path(args[0] if args else Path(__file__).resolve().parent / "_build" / "html")
    problems = check_site(root)
    for p in problems:
        print(p, file=sys.stderr)
    n = len(list(root.rglob("*.html")))
    print(f"{root}: {n} pages, {len(problems)} problem(s)")
    return 1 if problems else 0


if __name__ == "__main__":
    raise SystemExit(main())
