"""Screenshots of a built report's sections in headless Chromium, for review (issue 17).

    python scripts/screenshot_report.py out/report [--out-dir out/report/screens] [--width 1400]

The report is one page (``index.html``) with a ``<section id=KEY>`` per section.  For each
section this writes a page holding only that section (same style sheet, images from the report
directory), loads it in headless Chromium at the given window width, measures how wide the laid-out
page is (``scrollWidth`` above ``clientWidth``: the page itself scrolls sideways), takes a
tall screenshot, trims the blank bottom and cuts it into tiles of ``--tile`` pixels:
``screens/KEY_01.png``, ``KEY_02.png``, ...  The top of ``index.html`` (title and table of
contents) is ``screens/index.png``.  A summary is printed and written to ``screens/screens.json``.

Chromium is a review tool here, not a dependency of the package or its tests: it is looked for as
``chromium``, ``chromium-browser`` or ``google-chrome`` on ``PATH`` (``apt-get install chromium``
on Debian).  Images are cut with Pillow (installed with matplotlib).
"""

from __future__ import annotations

import argparse
import json
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

#: Executables tried, in order.
BROWSERS = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")

#: Height of the tall screenshot of one section (px); longer sections are cut at it (reported).
MAX_HEIGHT = 16000


def find_browser() -> str:
    """The first Chromium-like browser on ``PATH``; ``SystemExit`` naming the install command if none."""
    for name in BROWSERS:
        path = shutil.which(name)
        if path:
            return path
    raise SystemExit("no Chromium found on PATH (tried " + ", ".join(BROWSERS) + "); on Debian: apt-get install chromium")


def split_sections(index_html: str) -> tuple[str, list[tuple[str, str]]]:
    """The page's ``<head>`` and its ``(key, section HTML)`` pairs, in order."""
    head = index_html.split("<body>", 1)[0]
    sections = re.findall(r"(<section id='([^']+)'>.*?</section>)", index_html, flags=re.S)
    return head, [(key, html) for html, key in sections]


_MEASURE = ("<script>window.addEventListener('load', function () {"
            "document.title = 'scrollWidth=' + document.documentElement.scrollWidth"
            " + ';clientWidth=' + document.documentElement.clientWidth"
            " + ';scrollHeight=' + document.documentElement.scrollHeight; });</script>")


def _run(browser: str, args: list[str]) -> subprocess.CompletedProcess:
    base = [browser, "--headless", "--no-sandbox", "--disable-gpu", "--virtual-time-budget=5000"]
    return subprocess.run(base + args, capture_output=True, text=True, timeout=180)


def measure(browser: str, page: Path, width: int) -> dict[str, int]:
    """``scrollWidth`` and ``scrollHeight`` of ``page`` laid out in a ``width`` px wide window."""
    res = _run(browser, [f"--window-size={width},2000", "--dump-dom", page.as_uri()])
    m = re.search(r"<title>scrollWidth=(\d+);clientWidth=(\d+);scrollHeight=(\d+)</title>", res.stdout)
    return {"scroll_width": int(m.group(1)), "client_width": int(m.group(2)), "scroll_height": int(m.group(3))} if m else {}


def screenshot(browser: str, page: Path, png: Path, width: int, height: int) -> None:
    """A ``width`` x ``height`` screenshot of ``page`` into ``png``."""
    res = _run(browser, [f"--window-size={width},{height}", f"--screenshot={png}", page.as_uri()])
    if not png.is_file():
        raise SystemExit(f"chromium wrote no screenshot of {page}: {res.stderr[-500:]}")


def tiles(png: Path, out_stem: Path, tile: int, content_height: int | None) -> list[str]:
    """Cut ``png`` into tiles of ``tile`` px (blank bottom trimmed); returns the files written."""
    from PIL import Image, ImageChops

    img = Image.open(png).convert("RGB")
    if content_height:
        img = img.crop((0, 0, img.width, min(img.height, content_height + 20)))
    bg = Image.new("RGB", img.size, (255, 255, 255))
    box = ImageChops.difference(img, bg).getbbox()
    if box:
        img = img.crop((0, 0, img.width, min(img.height, box[3] + 20)))
    names = []
    for k, top in enumerate(range(0, img.height, tile), start=1):
        name = out_stem.with_name(f"{out_stem.name}_{k:02d}.png")
        img.crop((0, top, img.width, min(img.height, top + tile))).save(name)
        names.append(name.name)
    return names


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("report", type=Path, help="a built report directory (with index.html)")
    p.add_argument("--out-dir", type=Path, default=None, help="where the PNGs go (default REPORT/screens)")
    p.add_argument("--width", type=int, default=1400, help="window width in px (default 1400)")
    p.add_argument("--tile", type=int, default=2000, help="height of one screenshot tile in px (default 2000)")
    p.add_argument("--section", action="append", default=None, help="only these section keys (repeatable)")
    args = p.parse_args(argv)
    index = args.report / "index.html"
    if not index.is_file():
        raise SystemExit(f"{index}: no such file (build the report with: hybobs report --out-dir {args.report})")
    browser = find_browser()
    out = args.out_dir or args.report / "screens"
    out.mkdir(parents=True, exist_ok=True)
    head, sections = split_sections(index.read_text())
    summary: dict[str, dict] = {}
    with tempfile.TemporaryDirectory(dir=args.report, prefix=".screens-") as tmp:
        tmpdir = Path(tmp)
        base = f"<base href='{args.report.resolve().as_uri()}/'>"
        pages = [("index", head.replace("<head>", "<head>" + base) + _MEASURE
                  + index.read_text().split("<body>", 1)[1].split("<section", 1)[0] + "</body></html>")]
        pages += [(key, head.replace("<head>", "<head>" + base) + _MEASURE + "<body>" + html + "</body></html>")
                  for key, html in sections if not args.section or key in args.section]
        for key, html in pages:
            page = tmpdir / f"{key}.html"
            page.write_text(html)
            size = measure(browser, page, args.width)
            height = min(MAX_HEIGHT, size.get("scroll_height", MAX_HEIGHT) + 40)
            raw = tmpdir / f"{key}.png"
            screenshot(browser, page, raw, args.width, height)
            files = tiles(raw, out / key, args.tile, size.get("scroll_height"))
            summary[key] = {**size, "window_width": args.width, "overflows": size.get("scroll_width", 0) > size.get("client_width", args.width),
                            "cut_at_max_height": size.get("scroll_height", 0) + 40 > MAX_HEIGHT, "screenshots": files}
            flag = "  PAGE WIDER THAN THE WINDOW" if summary[key]["overflows"] else ""
            print(f"{key}: {size.get('scroll_width', '?')} x {size.get('scroll_height', '?')} px, "
                  f"{len(files)} screenshot(s){flag}")
    (out / "screens.json").write_text(json.dumps(summary, indent=2))
    print(f"screenshots in {out}")
    return 1 if any(s["overflows"] for s in summary.values()) else 0


if __name__ == "__main__":
    sys.exit(main())
