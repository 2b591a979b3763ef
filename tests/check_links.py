"""Link and image checker for built HTML: the report (``hybobs report``) and the Sphinx docs.

Parses every ``*.html`` file under a directory with the standard library's :mod:`html.parser` and
reports, without any network access:

* an ``<a href>`` to a local file that does not exist, or to an anchor (``#id``) that no element
  of the target page carries (``id=`` or ``<a name=>``);
* an ``<img src>`` that is missing, empty, or not a readable PNG, SVG, JPEG or GIF (checked by its
  first bytes, not its name);
* an ``<img>`` without an ``alt`` text, with a blank one, or with one that is only a file name or
  path (``alt='example_driveline.png'``, Sphinx's default ``alt='../_images/fig.png'``).

Links with a scheme (``https:``, ``mailto:``, ``data:``) or starting with ``//`` are external and
not checked.  Run it as ``python -m tests.check_links DIR [DIR ...]`` (exit status 1 and one line
per problem when something is broken); ``.ci/run`` runs it on ``docs/_build/html`` after
``make docs``, and ``tests/app/test_report_links.py`` on a freshly built report.
"""

from __future__ import annotations

import re
import sys
from dataclasses import dataclass, field
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import unquote, urlsplit

#: An alt text that is only a file name or a path to an image (what a figure shows is missing).
FILE_NAME_ALT = re.compile(r"^[\w./\\ -]*\.(png|svg|jpe?g|gif|webp|pdf)$", re.IGNORECASE)

#: Leading bytes of the image formats accepted in ``<img src>``.
_MAGIC = {b"\x89PNG\r\n\x1a\n": "png", b"\xff\xd8\xff": "jpeg", b"GIF87a": "gif", b"GIF89a": "gif"}


@dataclass
class _Page:
    ids: set[str] = field(default_factory=set)
    links: list[tuple[int, str]] = field(default_factory=list)
    images: list[tuple[int, str | None, str | None]] = field(default_factory=list)


class _Collector(HTMLParser):
    def __init__(self) -> None:
        super().__init__(convert_charrefs=True)
        self.page = _Page()

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        a = dict(attrs)
        line = self.getpos()[0]
        if a.get("id"):
            self.page.ids.add(a["id"])
        if tag == "a" and a.get("name"):
            self.page.ids.add(a["name"])
        if tag == "a" and a.get("href") is not None:
            self.page.links.append((line, a["href"]))
        if tag == "img":
            self.page.images.append((line, a.get("src"), a.get("alt")))

    handle_startendtag = handle_starttag


def _parse(path: Path) -> _Page:
    collector = _Collector()
    collector.feed(path.read_text(encoding="utf-8", errors="replace"))
    collector.close()
    return collector.page


def _external(url: str) -> bool:
    return url.startswith("//") or bool(urlsplit(url).scheme)


def image_kind(path: Path) -> str | None:
    """The format of the image file ``path`` from its first bytes (``"png"``, ``"svg"``, ...), ``None`` if not an image.

    Parameters
    ----------
    path : Path

    Returns
    -------
    str or None
    """
    try:
        head = path.read_bytes()[:512]
    except OSError:
        return None
    for magic, kind in _MAGIC.items():
        if head.startswith(magic):
            return kind
    text = head.decode("utf-8", errors="ignore").lstrip().lower()
    if text.startswith("<svg") or (text.startswith("<?xml") and "<svg" in text) or "<svg" in text[:300]:
        return "svg"
    return None


def alt_problem(alt: str | None, src: str | None) -> str | None:
    """Why ``alt`` does not describe its image (missing, blank, a file name), ``None`` if it does.

    Parameters
    ----------
    alt : str or None
        The ``alt`` attribute (``None`` when absent).
    src : str or None
        The image's ``src`` (an alt equal to its name or stem is a file name too).

    Returns
    -------
    str or None
    """
    if alt is None:
        return "no alt text"
    text = alt.strip()
    if not text:
        return "an empty alt text"
    name = Path(urlsplit(src or "").path).name
    if FILE_NAME_ALT.match(text) or (name and text in (name, Path(name).stem)):
        return f"an alt text that is a file name ({text!r}), not what the figure shows"
    return None


def check_html_tree(root: str | Path) -> list[str]:
    """Every broken internal link, broken image and missing or file-name alt text under ``root``.

    Parameters
    ----------
    root : path-like
        A directory of built HTML (``index.html`` and its figures), searched recursively, or one
        HTML file.

    Returns
    -------
    list of str
        One ``"page:line: problem"`` per problem; empty when every link and image is good.
    """
    root = Path(root).resolve()
    files = [root] if root.is_file() else sorted(root.rglob("*.html"))
    pages = {p.resolve(): _parse(p) for p in files}
    problems: list[str] = []

    def where(path: Path, line: int) -> str:
        try:
            shown = path.relative_to(root if root.is_dir() else root.parent)
        except ValueError:
            shown = path
        return f"{shown}:{line}"

    for path, page in pages.items():
        for line, href in page.links:
            if not href or _external(href):
                continue
            parts = urlsplit(href)
            target = (path.parent / unquote(parts.path)).resolve() if parts.path else path
            if parts.path and not target.exists():
                problems.append(f"{where(path, line)}: link to a missing file {href!r}")
                continue
            if target.is_dir():
                target = target / "index.html"
                if not target.exists():
                    problems.append(f"{where(path, line)}: link to a directory without index.html {href!r}")
                    continue
            if parts.fragment and target.suffix == ".html":
                ids = pages[target].ids if target in pages else _parse(target).ids
                if unquote(parts.fragment) not in ids:
                    problems.append(f"{where(path, line)}: link to a missing anchor {href!r}")
        for line, src, alt in page.images:
            if not src:
                problems.append(f"{where(path, line)}: <img> without a src")
            elif src.startswith("data:"):
                pass
            elif _external(src):
                problems.append(f"{where(path, line)}: <img> from the network {src!r} (not available offline)")
            else:
                file = (path.parent / unquote(urlsplit(src).path)).resolve()
                if not file.is_file():
                    problems.append(f"{where(path, line)}: missing image {src!r}")
                elif image_kind(file) is None:
                    problems.append(f"{where(path, line)}: {src!r} is not a readable PNG/SVG/JPEG/GIF image")
            why = alt_problem(alt, src)
            if why:
                problems.append(f"{where(path, line)}: <img src={src!r}> has {why}")
    return problems


def main(argv: list[str] | None = None) -> int:
    """``python -m tests.check_links DIR [DIR ...]``: print every problem; exit status 1 if any.

    Parameters
    ----------
    argv : list of str, optional
        The directories (default: ``sys.argv[1:]``).

    Returns
    -------
    int
    """
    dirs = sys.argv[1:] if argv is None else argv
    if not dirs:
        print("usage: python -m tests.check_links DIR [DIR ...]", file=sys.stderr)
        return 2
    bad = 0
    for d in dirs:
        if not Path(d).exists():
            print(f"{d}: no such directory", file=sys.stderr)
            return 2
        problems = check_html_tree(d)
        for p in problems:
            print(f"{d.rstrip('/')}/{p}")
        n_pages = 1 if Path(d).is_file() else sum(1 for _ in Path(d).rglob("*.html"))
        print(f"{d}: {n_pages} pages, {len(problems)} problems", file=sys.stderr)
        bad += len(problems)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
