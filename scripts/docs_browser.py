"""Open the built documentation site in headless Chromium and fail on anything broken.

Usage: ``python scripts/docs_browser.py [SITE] [--screenshots DIR]`` after ``bash scripts/docs.sh``
(SITE defaults to ``docs/_build/html``, DIR to ``docs/_build/screenshots``).

The site is served on a loopback port and every HTML page of it is visited in Chromium, driven by
Playwright. A page fails on

* a console error or an uncaught JavaScript exception;
* a request of the site that fails or answers 400 or more (a missing stylesheet, script, image);
* an image that does not load (``naturalWidth`` 0 once the page has loaded);
* a table wider than the page without the scroll hint of ``docs/_static/spine_docs.js``, or a
  page wider than the window (its right edge cut off);
* a link to a page of the site that does not exist, or to an anchor (``page.html#id``) that the
  page does not have. Links to other hosts are counted, not followed (no network is needed).

A few pages are kept as screenshots. The browser is Debian's ``chromium-headless-shell`` (``apt-get
install chromium-headless-shell``), found on PATH or at ``$CHROMIUM``; Playwright's own browser
download is not used. Prints the number of pages visited; exits 1 on any problem.
"""

from __future__ import annotations

import argparse
import functools
import http.server
import os
import shutil
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from urllib.parse import unquote, urldefrag, urlparse

ROOT = Path(__file__).resolve().parents[1]
SITE = ROOT / "docs" / "_build" / "html"
BROWSER_ARGS = [
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
]
# pages kept as screenshots (those that exist), relative to the site
SCREENSHOTS = (
    "index.html",
    "getting_started.html",
    "envs.html",
    "envs/SmaSpine-v1.html",
    "benchmark.html",
    "results.html",
)
VIEWPORT = {"width": 1280, "height": 900}

# What a page reports once loaded: its images that did not load, its links and its anchors.
_PAGE_FACTS_JS = """() => ({
  badImages: Array.from(document.images)
    .filter(i => !i.complete || i.naturalWidth === 0)
    .map(i => i.getAttribute('src')),
  links: Array.from(document.querySelectorAll('a[href]')).map(a => a.href),
  ids: Array.from(document.querySelectorAll('[id]')).map(e => e.id)
    .concat(Array.from(document.querySelectorAll('a[name]')).map(a => a.name)),
  unhintedWideTables: Array.from(document.querySelectorAll('.table-wrapper'))
    .filter(w => w.scrollWidth > w.clientWidth + 1 && !w.classList.contains('is-wide')).length,
  pageOverflow: document.documentElement.scrollWidth - window.innerWidth,
})"""


@dataclass
class Report:
    """What the visit found: pages visited, problems (one line each), links counted."""

    pages: int = 0
    problems: list[str] = field(default_factory=list)
    internal_links: int = 0
    external_links: int = 0


def chromium_path() -> str:
    """The Chromium binary: ``$CHROMIUM``, else ``chromium-headless-shell`` or ``chromium`` on PATH."""
    for candidate in (os.environ.get("CHROMIUM"), "chromium-headless-shell", "chromium"):
        if candidate and (found := shutil.which(candidate)):
            return found
    raise FileNotFoundError(
        "no Chromium found: install Debian's chromium-headless-shell "
        "(apt-get install chromium-headless-shell) or set CHROMIUM to its path"
    )


class _QuietHandler(http.server.SimpleHTTPRequestHandler):
    def log_message(self, format, *args):  # noqa: A002  (the base class's name)
        pass


@contextmanager
def serve(site: Path) -> Iterator[str]:
    """Serve ``site`` on a free loopback port; yields its base URL (ending in ``/``)."""
    handler = functools.partial(_QuietHandler, directory=str(site))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{server.server_address[1]}/"
    finally:
        server.shutdown()
        server.server_close()
        thread.join()


def site_pages(site: Path) -> list[str]:
    """Every HTML page of ``site``, as paths relative to it (``_static`` and sources excluded)."""
    skip = {"_static", "_sources", "_images", "_downloads"}
    return sorted(
        p.relative_to(site).as_posix()
        for p in site.rglob("*.html")
        if not skip & set(p.relative_to(site).parts[:-1])
    )


def _visit(page, url: str, rel: str, report: Report) -> dict:
    """Load one page; record its console errors, failed requests and broken images."""
    errors: list[str] = []
    on_console = lambda m: m.type == "error" and errors.append(f"console error: {m.text}")  # noqa: E731
    on_pageerror = lambda e: errors.append(f"JavaScript exception: {e}")  # noqa: E731
    on_failed = lambda r: errors.append(f"request failed: {r.url} ({r.failure})")  # noqa: E731
    on_response = lambda r: r.status >= 400 and errors.append(f"HTTP {r.status}: {r.url}")  # noqa: E731
    handlers = {
        "console": on_console,
        "pageerror": on_pageerror,
        "requestfailed": on_failed,
        "response": on_response,
    }
    for event, fn in handlers.items():
        page.on(event, fn)
    try:
        page.goto(url + rel, wait_until="load")
        facts = page.evaluate(_PAGE_FACTS_JS)
    finally:
        for event, fn in handlers.items():
            page.remove_listener(event, fn)
    errors += [f"image does not load: {src}" for src in facts["badImages"]]
    if facts["unhintedWideTables"]:
        errors.append(f"{facts['unhintedWideTables']} table(s) wider than the page without the scroll hint")
    if facts["pageOverflow"] > 0:
        errors.append(f"the page is {facts['pageOverflow']} px wider than the window (content cut off)")
    report.problems += [f"{rel}: {e}" for e in errors]
    return facts


def _check_links(
    base: str, site: Path, links: dict[str, list[str]], ids: dict[str, set[str]], report: Report
) -> None:
    """Every link of the site to the site: the file exists, and so does the anchor if there is one."""
    host = urlparse(base).netloc
    for rel, hrefs in links.items():
        for href in hrefs:
            parsed = urlparse(href)
            if parsed.scheme not in ("http", "https", "file") or parsed.netloc != host:
                report.external_links += parsed.scheme in ("http", "https")
                continue
            report.internal_links += 1
            target, anchor = urldefrag(href)
            path = unquote(urlparse(target).path).lstrip("/")
            if path == "" or path.endswith("/"):
                path += "index.html"
            if not (site / path).is_file():
                report.problems.append(f"{rel}: link to a missing page: {path}")
            elif anchor and path in ids and unquote(anchor) not in ids[path]:
                report.problems.append(f"{rel}: link to a missing anchor: {path}#{anchor}")


def check_site(site: Path = SITE, screenshots: Path | None = None) -> Report:
    """Visit every page of the built site ``site`` in headless Chromium (see the module docstring)."""
    from playwright.sync_api import sync_playwright  # noqa: PLC0415  (the docs extra)

    if not (site / "index.html").is_file():
        raise FileNotFoundError(f"no built site at {site} (run: bash scripts/docs.sh)")
    report = Report()
    links: dict[str, list[str]] = {}
    ids: dict[str, set[str]] = {}
    with serve(site) as base, sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=chromium_path(), args=BROWSER_ARGS)
        try:
            page = browser.new_page(viewport=VIEWPORT)
            for rel in site_pages(site):
                facts = _visit(page, base, rel, report)
                report.pages += 1
                links[rel] = facts["links"]
                ids[rel] = set(facts["ids"])
                if screenshots is not None and rel in SCREENSHOTS:
                    screenshots.mkdir(parents=True, exist_ok=True)
                    page.screenshot(path=str(screenshots / (rel.replace("/", "_")[:-5] + ".png")))
        finally:
            browser.close()
    _check_links(base, site, links, ids, report)
    return report


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument(
        "site", nargs="?", type=Path, default=SITE, help=f"the built site (default: {SITE.relative_to(ROOT)})"
    )
    ap.add_argument(
        "--screenshots",
        type=Path,
        default=SITE.parent / "screenshots",
        help="folder of the screenshots (default: docs/_build/screenshots)",
    )
    args = ap.parse_args(argv)
    report = check_site(args.site, args.screenshots)
    for p in report.problems:
        print(p)
    print(
        f"docs browser check: {report.pages} pages visited, {report.internal_links} links within the site "
        f"checked, {report.external_links} external links not followed, {len(report.problems)} problems"
    )
    return 1 if report.problems else 0


if __name__ == "__main__":
    sys.exit(main())
