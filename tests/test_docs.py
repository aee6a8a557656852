"""The documentation site (issue 16 part 1): `mkdocs build --strict` succeeds and holds the key pages.

The build runs every example of the chapter pages and every built-in scenario of the gallery, so
a failing example, a broken link or a bad docstring reference fails this test (strict mode).
Nothing is skipped: without mkdocs (the `docs` extra) the test fails.
"""

from __future__ import annotations

import importlib.util
import os
import re
import subprocess
import sys
import types
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
CHAPTER = ["9.1-interaction", "9.2-compliance", "9.3-impedance", "9.4-force", "9.5-constrained-motion",
           "9.6-constraints", "9.7-hybrid"]


@pytest.fixture(scope="session")
def site(tmp_path_factory) -> Path:
    """The site built once, strictly, into a temporary folder (session scope: a module fixture was built twice on one
    worker when another module's tests ran between this module's; the build takes minutes)."""
    out = tmp_path_factory.mktemp("site")
    env = {**os.environ, "FORCECONTROL_DOCS_CACHE": str(out.parent / "generated"), "NO_MKDOCS_2_WARNING": "1",
           "PYTHONPATH": os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")])}
    proc = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(out)],
        cwd=ROOT, env=env, capture_output=True, text=True, timeout=900,
    )
    assert proc.returncode == 0, f"mkdocs build --strict failed:\n{proc.stdout}\n{proc.stderr[-6000:]}"
    (out.parent / "build.log").write_text(proc.stderr, encoding="utf-8")  # read by the cross-reference test
    return out


def test_mkdocs_installed():
    """The docs tools are installed (the `docs` extra, part of `test`): a missing mkdocs is a failure, not a skip."""
    for mod in ("mkdocs", "material", "mkdocstrings", "mkdocstrings_handlers.python", "pymdownx"):
        assert importlib.util.find_spec(mod) is not None, f"{mod} missing: pip install -e '.[docs]'"


def test_key_pages(site):
    """Home, getting started, conventions, one page per chapter section and the API reference are built."""
    for page in ["index.html", "getting-started/index.html", "conventions/index.html", "api/controllers/index.html"]:
        assert (site / page).is_file(), page
    for name in CHAPTER:
        html = (site / "chapter" / name / "index.html").read_text(encoding="utf-8")
        assert "arithmatex" in html, f"{name}: no equations"
        assert "<img" in html, f"{name}: no figure"
        assert "Output (computed when this page was built)" in html, f"{name}: example not run"
    api = (site / "api" / "controllers" / "index.html").read_text(encoding="utf-8")
    assert "ImpedanceController" in api and "(9.31)" in api  # from the docstrings


def test_gallery_has_every_scenario_with_its_figures(site):
    """Every built-in scenario has a gallery page whose figures were generated during the build."""
    from forcecontrol.scenarios import list_scenarios

    index = (site / "gallery" / "index.html").read_text(encoding="utf-8")
    for name in list_scenarios():
        page = site / "gallery" / name / "index.html"
        assert page.is_file() and name in index, name
        html = page.read_text(encoding="utf-8")
        imgs = [s.split('"')[0] for s in html.split('src="../img/')[1:]]
        assert imgs, f"{name}: no figure"
        for img in imgs:
            assert (site / "gallery" / "img" / img).stat().st_size > 5_000, img


def test_images_of_chapter_pages_exist(site):
    """The block diagrams and the animation referenced by the chapter pages are in the site."""
    for img in ["compliance.png", "impedance.png", "force-inner-position.png", "force-inner-velocity.png",
                "force-parallel.png", "hybrid.png", "constraints.png", "interaction.gif"]:
        assert (site / "chapter" / "img" / img).stat().st_size > 5_000, img


def _hooks():
    spec = importlib.util.spec_from_file_location("docs_hooks", ROOT / "docs" / "hooks.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_failing_example_fails_the_build():
    """An example that raises stops the build (PluginError naming the page), even outside strict mode."""
    from mkdocs.exceptions import PluginError

    hooks = _hooks()
    page = types.SimpleNamespace(file=types.SimpleNamespace(src_uri="chapter/broken.md"))
    md = "# x\n\n```python\nprint('fine')\n```\n\n```python\n1 / 0\n```\n"
    with pytest.raises(PluginError, match=r"chapter/broken\.md failed(.|\n)*ZeroDivisionError"):
        hooks.on_page_markdown(md, page, {}, None)


def test_example_output_is_shown():
    """A working example's printed output is inserted under it; pages outside the chapter are left alone."""
    hooks = _hooks()
    page = types.SimpleNamespace(file=types.SimpleNamespace(src_uri="chapter/ok.md"))
    out = hooks.on_page_markdown("```python\nx = 6 * 7\nprint(x)\n```\n", page, {}, None)
    assert "Output (computed when this page was built)" in out and "    42" in out
    other = types.SimpleNamespace(file=types.SimpleNamespace(src_uri="api/x.md"))
    assert hooks.on_page_markdown("```python\n1 / 0\n```\n", other, {}, None).startswith("```python")



def test_examples_leave_no_folder_behind(tmp_path, monkeypatch):
    """The folder an example page writes into is removed after the page, also when an example fails (every build
    used to leave one empty folder per page in the system's temporary folder)."""
    import tempfile

    from mkdocs.exceptions import PluginError

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    hooks = _hooks()
    page = types.SimpleNamespace(file=types.SimpleNamespace(src_uri="chapter/writes.md"))
    out = hooks.on_page_markdown("```python\nopen('x.txt', 'w').write('x')\nprint('written')\n```\n", page, {}, None)
    assert "    written" in out
    with pytest.raises(PluginError):
        hooks.on_page_markdown("```python\nopen('y.txt', 'w').write('y')\n1 / 0\n```\n", page, {}, None)
    assert list(tmp_path.iterdir()) == [], "the examples' working folders were left behind"

# ---------------------------------------------------------------------------------------------- issue 32, item 5
SITE_URL = "https://forcecontrol.github.io/forcecontrol/"
ROLE_TEXT = re.compile(r":(?:py:)?(?:class|func|meth|attr|mod|data|exc|obj|const):(?:<code>|`)")
EXTERNAL_ASSET = re.compile(r'<(?:script|img|iframe)\b[^>]*\bsrc="(?:https?:)?//|<link\b(?=[^>]*\brel="(?:stylesheet|preconnect|'
                            r'preload|modulepreload|icon|dns-prefetch)")[^>]*\bhref="(?:https?:)?//', re.I)


def _pages(site: Path) -> list[Path]:
    return sorted(site.rglob("*.html"))


def test_no_sphinx_role_reaches_a_page_and_references_are_links(site):
    """No `:class:`-style text is left in any page; the docstrings' references are links to anchors that exist."""
    stray = {str(p.relative_to(site)): ROLE_TEXT.findall(p.read_text(encoding="utf-8")) for p in _pages(site)}
    assert not {k: v for k, v in stray.items() if v}
    links = 0
    for page in sorted((site / "api").rglob("index.html")):
        html = page.read_text(encoding="utf-8")
        for href in re.findall(r'<a class="autorefs autorefs-internal"[^>]*href="([^"]+)"', html):
            target, _, anchor = href.partition("#")
            dest = (page.parent / target / "index.html").resolve() if target else page
            assert anchor and f'id="{anchor}"' in dest.read_text(encoding="utf-8"), f"{page}: {href}"
            links += 1
    log = (site.parent / "build.log").read_text(encoding="utf-8")
    counts = re.search(r"cross-references: (\d+) linked, (\d+) linked from an old path, (\d+) to other packages \(code\), "
                       r"(\d+) to objects no page documents \(code\), (\d+) missing", log)
    assert counts, log[-3000:]
    linked, stale, external, undocumented, missing = map(int, counts.groups())
    assert missing == 0 and links >= linked + stale > 300  # 276 literal roles in the API pages before (issue 32)
    assert undocumented < 0.1 * (linked + stale)
    api = (site / "api" / "controllers" / "index.html").read_text(encoding="utf-8")
    assert 'href="../laws/#forcecontrol.laws"><code>forcecontrol.laws</code></a>' in api  # :mod:`forcecontrol.laws`
    assert 'href="#forcecontrol.controllers.AdmittanceController.reset"><code>reset</code></a>' in api  # :meth:`reset`


def test_no_page_loads_anything_from_another_site(site):
    """No page loads a script, stylesheet, font or image from a CDN: MathJax, its fonts and its licence are in the site."""
    for page in _pages(site):
        html = page.read_text(encoding="utf-8")
        assert not EXTERNAL_ASSET.findall(html), f"{page}: {EXTERNAL_ASSET.findall(html)}"
        assert "cdn.jsdelivr.net" not in html and "fonts.googleapis.com" not in html, page
    chapter = (site / "chapter" / "9.7-hybrid" / "index.html").read_text(encoding="utf-8")
    scripts = re.findall(r'<script src="([^"]+)"', chapter)
    assert "../../javascripts/mathjax/tex-chtml-full.js" in scripts, scripts
    mathjax = site / "javascripts" / "mathjax"
    assert (mathjax / "tex-chtml-full.js").stat().st_size > 1_000_000
    assert "Apache License" in (mathjax / "LICENSE").read_text(encoding="utf-8")
    assert len(list((mathjax / "output" / "chtml" / "fonts" / "woff-v2").glob("*.woff"))) == 23
    for js in site.rglob("*.js"):
        assert "cdn.jsdelivr.net/npm/mathjax" not in js.read_text(encoding="utf-8", errors="replace"), js


def test_sitemap_lists_every_page_and_the_404_page_keeps_its_style(site):
    """`site_url` fills the sitemap with the published addresses; the 404 page's assets resolve from any depth."""
    sitemap = (site / "sitemap.xml").read_text(encoding="utf-8")
    locs = re.findall(r"<loc>([^<]+)</loc>", sitemap)
    pages = [p for p in _pages(site) if p.name == "index.html"]
    assert len(locs) == len(pages) and all(u.startswith(SITE_URL) for u in locs)
    assert SITE_URL + "chapter/9.3-impedance/" in locs
    html = (site / "404.html").read_text(encoding="utf-8")
    assets = re.findall(r'<(?:link rel="stylesheet"|script) (?:href|src)="([^"]+)"', html)
    assert len(assets) >= 4 and any(a.endswith(".css") for a in assets), assets
    for a in assets:  # absolute paths under the site's path, so they work at /forcecontrol/any/missing/page
        assert a.startswith("/forcecontrol/"), a
        assert (site / a.removeprefix("/forcecontrol/")).is_file(), a
    assert 'href="https://github.com/forcecontrol/forcecontrol"' in html  # repo_url, in the header


CHROMIUM = Path("/usr/bin/chromium")
CHROMEDRIVER = Path("/usr/bin/chromedriver")


def _browser_missing() -> list[str]:
    missing = [str(p) for p in (CHROMIUM, CHROMEDRIVER) if not p.exists()]
    if importlib.util.find_spec("selenium") is None:
        missing.append("selenium (pip install 'forcecontrol[browser]')")
    if missing and os.environ.get("FORCECONTROL_REQUIRE_BROWSER"):
        pytest.fail(f"FORCECONTROL_REQUIRE_BROWSER is set but {', '.join(missing)} is missing", pytrace=False)
    return missing


WAIT_FOR_MATHJAX = """
const done = arguments[arguments.length - 1];
const t0 = performance.now();
(function poll() {
  if (window.MathJax && MathJax.startup && MathJax.startup.promise) {
    MathJax.startup.promise.then(() => document.fonts.ready).then(() => done(true), e => done(String(e)));
  } else if (performance.now() - t0 > 20000) { done("MathJax did not start"); } else { setTimeout(poll, 50); }
})();
"""


def test_equations_render_offline_in_chromium(site, tmp_path):
    """Headless Chromium, with every name but 127.0.0.1 unresolvable, renders each equation with MathJax's fonts."""
    if missing := _browser_missing():
        pytest.skip(f"no headless browser: {', '.join(missing)} missing")
    import functools
    import http.server
    import json
    import threading

    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    class Quiet(http.server.SimpleHTTPRequestHandler):
        def log_message(self, *args):
            pass

    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), functools.partial(Quiet, directory=str(site)))
    threading.Thread(target=server.serve_forever, daemon=True).start()
    base = f"http://127.0.0.1:{server.server_address[1]}/"
    opts = webdriver.ChromeOptions()
    opts.binary_location = str(CHROMIUM)
    for arg in ("--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                "--disable-background-networking", "--disable-component-update", "--disable-sync",
                "--host-resolver-rules=MAP * ~NOTFOUND , EXCLUDE 127.0.0.1",  # no network but this machine
                f"--user-data-dir={tmp_path / 'profile'}", "--window-size=1280,900"):
        opts.add_argument(arg)
    opts.set_capability("goog:loggingPrefs", {"performance": "ALL"})
    driver = webdriver.Chrome(service=Service(str(CHROMEDRIVER)), options=opts)
    try:
        driver.set_page_load_timeout(60)
        driver.set_script_timeout(40)
        for name in ("9.7-hybrid", "9.3-impedance"):
            expected = (site / "chapter" / name / "index.html").read_text(encoding="utf-8").count('class="arithmatex"')
            driver.get(f"{base}chapter/{name}/")
            assert driver.execute_async_script(WAIT_FOR_MATHJAX) is True
            state = driver.execute_script("""
                const eqs = Array.from(document.querySelectorAll('.arithmatex'));
                const glyph = document.querySelector('mjx-container mjx-c');
                return {eqs: eqs.length, typeset: eqs.filter(e => e.querySelector('mjx-container')).length,
                        raw: eqs.map(e => e.textContent).filter(t => t.includes('\\\\[') || t.includes('\\\\(')).length,
                        glyph: glyph ? getComputedStyle(glyph, '::before').content : 'none',
                        width: Math.min(...eqs.map(e => e.getBoundingClientRect().width)),
                        fonts: Array.from(document.fonts).filter(f => f.status === 'loaded').map(f => f.family)};""")
            assert expected >= 3 and state["eqs"] == expected and state["typeset"] == expected, state
            assert state["raw"] == 0 and state["glyph"] not in ("none", "normal", '""') and state["width"] > 20, state
            assert "MJXTEX-I" in state["fonts"], state  # the italic maths font, loaded from the site
        requests = {}
        for entry in driver.get_log("performance"):
            msg = json.loads(entry["message"])["message"]
            if msg["method"] == "Network.requestWillBeSent":
                requests[msg["params"]["request"]["url"]] = msg["params"].get("type")
    finally:
        driver.quit()
        server.shutdown()
    outside = {u: t for u, t in requests.items() if u.startswith(("http:", "https:", "ws:", "wss:")) and not u.startswith(base)}
    # Material asks GitHub for the repository's star count (repo_url): it fails quietly offline, and nothing else leaves.
    assert all(u.startswith("https://api.github.com/repos/forcecontrol/forcecontrol") for u in outside), outside
    assert not [u for u, t in outside.items() if t in ("Script", "Stylesheet", "Font", "Image")], outside
    assert any(u.endswith("tex-chtml-full.js") for u in requests) and any(u.endswith(".woff") for u in requests)
