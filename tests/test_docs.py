"""The documentation site (issue 16 part 1): `mkdocs build --strict` succeeds and holds the key pages.

The build runs every example of the chapter pages and every built-in scenario of the gallery, so
a failing example, a broken link or a bad docstring reference fails this test (strict mode).
Nothing is skipped: without mkdocs (the `docs` extra) the test fails.
"""

from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
import types
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
CHAPTER = ["9.1-interaction", "9.2-compliance", "9.3-impedance", "9.4-force", "9.5-constrained-motion",
           "9.6-constraints", "9.7-hybrid"]


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    """The site built once, strictly, into a temporary folder."""
    out = tmp_path_factory.mktemp("site")
    env = {**os.environ, "FORCECONTROL_DOCS_CACHE": str(out.parent / "generated"), "NO_MKDOCS_2_WARNING": "1",
           "PYTHONPATH": os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")])}
    proc = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(out)],
        cwd=ROOT, env=env, capture_output=True, text=True, timeout=900,
    )
    assert proc.returncode == 0, f"mkdocs build --strict failed:\n{proc.stdout}\n{proc.stderr[-6000:]}"
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
