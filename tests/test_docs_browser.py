"""The browser check of the documentation site (scripts/docs_browser.py), in headless Chromium.

The checker is run on small sites written here: a clean one passes, and each kind of breakage
(a missing image, a link to a missing page or anchor, a console error, a JavaScript exception, a
missing script) is reported. The built site itself (docs/_build/html, from ``bash scripts/docs.sh``)
is checked when it exists; CI builds it and runs ``python scripts/docs_browser.py`` after the
main suite. Skipped without Playwright (the ``docs`` extra) or Debian's chromium-headless-shell.
"""

from __future__ import annotations

import importlib.util
import shutil
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "scripts"))
import docs_browser  # noqa: E402

pytestmark = [
    pytest.mark.skipif(
        importlib.util.find_spec("playwright") is None, reason="needs playwright (docs extra)"
    ),
    pytest.mark.skipif(
        not any(shutil.which(c) for c in ("chromium-headless-shell", "chromium")),
        reason="needs Debian's chromium-headless-shell",
    ),
]

# a 1x1 PNG
PIXEL = bytes.fromhex(
    "89504e470d0a1a0a0000000d49484452000000010000000108060000001f15c489"
    "0000000d49444154789c6360f8ffff3f0005fe02fea7d6a4b00000000049454e44ae426082"
)


def _page(body: str, title: str = "page") -> str:
    return f"<!doctype html><html><head><title>{title}</title></head><body>{body}</body></html>"


def _site(tmp_path: Path, index_body: str) -> Path:
    site = tmp_path / "html"
    (site / "sub").mkdir(parents=True)
    (site / "pixel.png").write_bytes(PIXEL)
    (site / "index.html").write_text(_page(index_body))
    (site / "sub" / "other.html").write_text(
        _page('<h2 id="part">part</h2><img src="../pixel.png" alt="pixel"><a href="../index.html">home</a>')
    )
    return site


def test_clean_site_passes_and_keeps_screenshots(tmp_path):
    body = '<img src="pixel.png" alt="p"><a href="sub/other.html#part">other</a>'
    site = _site(tmp_path, body + '<a href="https://example.org/">outside</a>')
    shots = tmp_path / "shots"
    report = docs_browser.check_site(site, shots)
    assert report.problems == []
    assert report.pages == 2
    assert report.internal_links == 2 and report.external_links == 1
    assert (shots / "index.png").stat().st_size > 0


@pytest.mark.parametrize(
    ("body", "expected"),
    [
        ('<img src="missing.png" alt="x">', "image does not load: missing.png"),
        ('<img src="pixel.png" alt="x"><a href="nowhere.html">x</a>', "link to a missing page: nowhere.html"),
        ('<a href="sub/other.html#nothere">x</a>', "link to a missing anchor: sub/other.html#nothere"),
        ("<script>console.error('boom')</script>", "console error: boom"),
        ("<script>undefined_function()</script>", "JavaScript exception"),
        ('<script src="_static/missing.js"></script>', "HTTP 404"),
        (
            '<div class="table-wrapper" style="width:200px;overflow-x:auto"><table><tr>'
            '<td style="min-width:900px">wide</td></tr></table></div>',
            "table(s) wider than the page without the scroll hint",
        ),
        ('<div style="width:3000px">wide</div>', "px wider than the window"),
    ],
)
def test_each_breakage_is_reported(tmp_path, body, expected):
    report = docs_browser.check_site(_site(tmp_path, body))
    assert any(p.startswith("index.html: ") and expected in p for p in report.problems), report.problems


def test_missing_site_is_one_clear_error(tmp_path):
    with pytest.raises(FileNotFoundError, match="no built site"):
        docs_browser.check_site(tmp_path / "nothing")


@pytest.mark.skipif(
    not (docs_browser.SITE / "index.html").is_file(), reason="the site is not built (bash scripts/docs.sh)"
)
def test_built_site_has_no_broken_page():
    report = docs_browser.check_site(docs_browser.SITE)
    assert report.problems == []
    env_pages = [p for p in docs_browser.site_pages(docs_browser.SITE) if p.startswith("envs/")]
    assert len(env_pages) >= 13  # one per registered id and their index
