"""Check that a built HTML site loads nothing from another host.

The documentation is read offline (a laptop on a train, a machine behind a firewall): its maths
is rendered by a MathJax copied into the site (``sphinx-mathjax-offline``), and its theme's scripts,
styles and fonts are local.  This walks every ``*.html`` file under a directory with the standard
library's :mod:`html.parser` and reports each resource the browser would fetch by itself from a
URL with a host: ``<script src>``, ``<link href>`` (stylesheets, fonts, preloads, icons),
``<img src>``, ``<iframe src>``, ``<source src>``, ``<video src>``, ``<audio src>``, ``<embed src>``
and ``<object data>``; and in the site's stylesheets, each ``url(...)`` and ``@import`` of a
URL with a host (web fonts).  Plain links (``<a href>``) to other sites are fine: they are followed only
when clicked.

Run it as ``python -m tests.check_offline DIR`` (exit status 1 and one line per remote resource);
``.ci/run`` runs it on ``docs/_build/html`` after ``make docs``.
"""

from __future__ import annotations

import re
import sys
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import urlsplit

#: tag -> the attribute holding the URL the browser loads without a click
LOADED = {"script": "src", "link": "href", "img": "src", "iframe": "src", "source": "src",
          "video": "src", "audio": "src", "embed": "src", "object": "data"}


def is_remote(url: str) -> bool:
    """Whether ``url`` names another host (``https://cdn...``, ``//cdn...``); ``data:`` URLs are local."""
    url = url.strip()
    if url.startswith("//"):
        return True
    parts = urlsplit(url)
    return parts.scheme not in ("", "data", "file") or bool(parts.netloc)


class _Collector(HTMLParser):
    def __init__(self) -> None:
        super().__init__(convert_charrefs=True)
        self.remote: list[tuple[int, str, str]] = []

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        attr = LOADED.get(tag)
        if attr is None:
            return
        a = dict(attrs)
        if tag == "link" and (a.get("rel") or "").lower() in ("canonical", "alternate", "search", "next", "prev"):
            return  # metadata, not fetched
        url = a.get(attr)
        if url and is_remote(url):
            self.remote.append((self.getpos()[0], tag, url))

    handle_startendtag = handle_starttag


#: ``url(...)`` and ``@import "..."`` in a stylesheet
_CSS_URL = re.compile(r"""url\(\s*['"]?([^'")\s]+)|@import\s+['"]([^'"]+)""")


def remote_resources(root: Path) -> list[str]:
    """``"file:line: <tag> url"`` for each resource of the pages (and stylesheets) under ``root``
    loaded from another host."""
    problems = []
    for sheet in sorted(root.rglob("*.css")):
        for number, line in enumerate(sheet.read_text(encoding="utf-8", errors="replace").splitlines(), 1):
            for match in _CSS_URL.finditer(line):
                url = match.group(1) or match.group(2)
                if is_remote(url):
                    problems.append(f"{sheet.relative_to(root)}:{number}: <css> {url}")
    for page in sorted(root.rglob("*.html")):
        collector = _Collector()
        collector.feed(page.read_text(encoding="utf-8", errors="replace"))
        collector.close()
        problems += [f"{page.relative_to(root)}:{line}: <{tag}> {url}" for line, tag, url in collector.remote]
    return problems


def main(argv: list[str]) -> int:
    if not argv:
        print("usage: python -m tests.check_offline DIR [DIR ...]", file=sys.stderr)
        return 2
    problems = []
    pages = 0
    for arg in argv:
        root = Path(arg)
        if not root.is_dir():
            print(f"{arg}: not a directory", file=sys.stderr)
            return 2
        pages += len(list(root.rglob("*.html")))
        problems += remote_resources(root)
    for line in problems:
        print(line)
    print(f"{pages} pages, {len(problems)} resources from another host", file=sys.stderr)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
