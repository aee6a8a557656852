"""Sphinx-style cross-references of the docstrings become links of the site (issue 32, item 5).

``docs/sphinx_roles.py`` resolves each role (``:class:`X```) against the package with griffe and
``docs/hooks.py`` makes it an autorefs link at ``on_env``. These tests use a small package written
here, whose objects and expected targets are known by construction, and a small MkDocs project
that carries the project's own strictness and link-validation settings (no gallery: seconds).
"""

from __future__ import annotations

import importlib.util
import logging
import os
import subprocess
import sys
import textwrap
import types
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"

PKG_INIT = '''
"""The package: see :mod:`.sub` and :class:`~rolespkg.sub.Thing`."""
from rolespkg.sub import Thing

__all__ = ["Thing"]
'''
PKG_SUB = '''
"""Things."""

LIMIT = 3
"""The bound."""


class Base:
    """The base."""

    def reset(self):
        """Forget."""


class Thing(Base):
    """A thing.

    :meth:`reset` clears it, :data:`LIMIT` bounds it, :func:`numpy.zeros` fills it,
    :class:`Its base <rolespkg.sub.Base>`, :func:`!not_linked`, :class:`rolespkg.old.Gadget`,
    :attr:`later`, :func:`~rolespkg.sub.helper()`.
    """

    def go(self):
        """Go; see :meth:`Thing.reset` and :func:`helper`."""


def helper():
    """Help."""


class Gadget:
    """A gadget."""
'''


def _roles():
    sys.path.insert(0, str(DOCS))
    try:
        spec = importlib.util.spec_from_file_location("sphinx_roles_under_test", DOCS / "sphinx_roles.py")
        mod = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(mod)
        return mod
    finally:
        sys.path.remove(str(DOCS))


def _package(tmp_path: Path, extra: str = "") -> Path:
    src = tmp_path / "src" / "rolespkg"
    src.mkdir(parents=True)
    (src / "__init__.py").write_text(PKG_INIT, encoding="utf-8")
    (src / "sub.py").write_text(PKG_SUB + extra, encoding="utf-8")
    return tmp_path / "src"


def _load(tmp_path: Path, roles):
    import griffe

    return griffe.load("rolespkg", search_paths=[str(_package(tmp_path))],
                       extensions=griffe.load_extensions(roles.SphinxRoles(package="rolespkg")))


class FakeAutorefs:
    """The identifiers a site documents, as autorefs answers for them."""

    def __init__(self, known):
        self.known = set(known)

    def get_item_url(self, identifier):
        if identifier not in self.known:
            raise KeyError(identifier)
        return f"page/#{identifier}"


def _page(content: str):
    return types.SimpleNamespace(content=content, file=types.SimpleNamespace(src_uri="api/x.md"))


def test_roles_resolve_from_the_docstrings_scope(tmp_path):
    """Each role form finds the object Sphinx would: relative, inherited, `~`, titled, `!`, external, moved."""
    roles = _roles()
    pkg = _load(tmp_path, roles)
    doc = pkg["sub.Thing"].docstring.value
    markers = {m["text"]: (m["kind"], m["ids"].split()) for m in roles.MARKER.finditer(doc)}
    assert markers["<code>reset</code>"] == ("found", ["rolespkg.sub.Thing.reset", "rolespkg.sub.Base.reset",
                                                       "rolespkg.sub.Thing", "rolespkg.sub.Base", "rolespkg.sub"])
    assert markers["<code>LIMIT</code>"][1][0] == "rolespkg.sub.LIMIT"
    assert markers["<code>numpy.zeros</code>"] == ("external", [])
    assert markers["<code>Its base</code>"][1][0] == "rolespkg.sub.Base"
    assert markers["<code>rolespkg.old.Gadget</code>"] == ("stale", ["rolespkg.sub.Gadget", "rolespkg.sub"])
    assert markers["<code>later</code>"] == ("attribute", ["rolespkg.sub.Thing", "rolespkg.sub"])
    assert markers["<code>helper()</code>"][1][0] == "rolespkg.sub.helper"
    assert "`not_linked`" in doc and ":func:" not in doc and ":meth:" not in doc
    go = {m["text"]: m["ids"].split()[0] for m in roles.MARKER.finditer(pkg["sub.Thing.go"].docstring.value)}
    assert go == {"<code>Thing.reset</code>": "rolespkg.sub.Thing.reset", "<code>helper</code>": "rolespkg.sub.helper"}
    top = {m["text"]: m["ids"].split()[0] for m in roles.MARKER.finditer(pkg.docstring.value)}
    assert top == {"<code>.sub</code>": "rolespkg.sub", "<code>Thing</code>": "rolespkg.sub.Thing"}


def test_markers_become_links_to_the_closest_documented_object(tmp_path, caplog):
    """A marker links its first documented identifier; the rest become code text, counted; none stays a role."""
    roles = _roles()
    doc = _load(tmp_path, roles)["sub.Thing"].docstring.value
    page = _page(doc)
    with caplog.at_level(logging.INFO, logger="mkdocs.plugins.forcecontrol.sphinx_roles"):
        counts = roles.resolve_markers([page], FakeAutorefs({"rolespkg.sub.Thing", "rolespkg.sub", "rolespkg.sub.LIMIT"}))
    html = page.content
    assert '<autoref identifier="rolespkg.sub.Thing"><code>reset</code></autoref>' in html  # the inherited method's class
    assert '<autoref identifier="rolespkg.sub.LIMIT"><code>LIMIT</code></autoref>' in html
    assert '<autoref identifier="rolespkg.sub"><code>rolespkg.old.Gadget</code></autoref>' in html
    assert "fc-xref" not in html and "<code>numpy.zeros</code>" in html and "<code>later</code>" in html
    assert counts["external"] == 1 and counts["stale"] == 1 and counts["missing"] == 0 and counts["stray"] == 0
    assert any("rolespkg.old.Gadget" in r.getMessage() and "old path" in r.getMessage() for r in caplog.records)


def test_a_missing_target_or_a_stray_role_is_a_warning(tmp_path, caplog):
    """A role whose target is nowhere in the package, or a role left in a page, logs a warning naming it."""
    roles = _roles()
    pkg = _load(tmp_path, roles)
    holder = pkg["sub.Thing.go"]
    holder.docstring.value = roles.convert(":class:`Nowhere` and :func:`helper`", holder, roles._Resolver(pkg))
    page = _page(holder.docstring.value + "<p>see :class:<code>Left</code></p>")
    with caplog.at_level(logging.WARNING, logger="mkdocs.plugins.forcecontrol.sphinx_roles"):
        counts = roles.resolve_markers([page], FakeAutorefs({"rolespkg.sub.helper"}))
    warnings = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert counts["missing"] == 1 and counts["stray"] == 1 and counts["linked"] == 1
    assert any("class:Nowhere in rolespkg.sub.Thing.go" in w for w in warnings)
    assert any(":class:<code>Left</code>" in w for w in warnings)


def _mini_site(tmp_path: Path, docs: dict[str, str], *, api: bool, extra: str = "",
               strict: bool = True) -> subprocess.CompletedProcess:
    """Build a small site with the project's `strict` (unless `strict=False`) and `validation` settings (and its roles
    machinery if `api`)."""
    project = yaml.load((ROOT / "mkdocs.yml").read_text(encoding="utf-8"), Loader=yaml.SafeLoader)
    cfg = {"site_name": "mini", "docs_dir": "docs", "strict": project["strict"] and strict, "validation": project["validation"],
           "theme": {"name": "mkdocs"}, "nav": list(docs)}
    if api:
        handler = project["plugins"][1]["mkdocstrings"]["handlers"]["python"]
        options = {**handler["options"], "extensions": [{f"{DOCS / 'sphinx_roles.py'}:SphinxRoles": {"package": "rolespkg"}}]}
        cfg["plugins"] = [{"mkdocstrings": {"handlers": {"python": {"paths": [str(_package(tmp_path, extra))],
                                                                      "options": options}}}}]
        (tmp_path / "mini_hooks.py").write_text(textwrap.dedent(f"""
            import sys
            sys.path.insert(0, {str(DOCS)!r})
            from hooks import on_env  # noqa: F401  (the project's hook, alone)
            """), encoding="utf-8")
        cfg["hooks"] = ["mini_hooks.py"]
    (tmp_path / "docs").mkdir(parents=True)
    for name, text in docs.items():
        (tmp_path / "docs" / name).write_text(textwrap.dedent(text), encoding="utf-8")
    (tmp_path / "mkdocs.yml").write_text(yaml.safe_dump(cfg), encoding="utf-8")
    env = {**os.environ, "NO_MKDOCS_2_WARNING": "1",
           "PYTHONPATH": os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")])}
    return subprocess.run([sys.executable, "-m", "mkdocs", "build", "--site-dir", str(tmp_path / "site")],
                          cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300)


def test_strict_build_fails_on_a_missing_cross_reference(tmp_path):
    """A docstring role to an object that does not exist, or to an old path, fails the strict build and names the role."""
    docs = {"index.md": "# API\n\n::: rolespkg.sub\n"}
    proc = _mini_site(tmp_path / "stale", docs, api=True)
    assert proc.returncode != 0  # the package as written names rolespkg.old.Gadget, an old path: fix the docstring
    assert "rolespkg.old.Gadget" in proc.stderr and "old path" in proc.stderr, proc.stderr[-3000:]
    proc = _mini_site(tmp_path / "good", docs, api=True, strict=False)
    assert proc.returncode == 0, proc.stderr[-3000:]  # without strict, the old path is still linked to its new place
    html = (tmp_path / "good" / "site" / "index.html").read_text(encoding="utf-8")
    for target, text in [("Base.reset", "reset"), ("helper", "helper"), ("Gadget", "rolespkg.old.Gadget"), ("LIMIT", "LIMIT")]:
        assert f'href="#rolespkg.sub.{target}"><code>{text}</code></a>' in html, target
    assert ":meth:" not in html and ":class:" not in html and "fc-xref" not in html
    proc = _mini_site(tmp_path / "bad", docs, api=True, extra='\n\ndef broken():\n    """Uses :class:`NoSuchThing`."""\n')
    assert proc.returncode != 0
    assert "class:NoSuchThing in rolespkg.sub.broken" in proc.stderr, proc.stderr[-3000:]


@pytest.mark.parametrize("link, what", [("[gone](missing.md)", "missing.md"),
                                        ("[gone](other.md#no-such-heading)", "no-such-heading")])
def test_strict_build_fails_on_a_broken_internal_link(tmp_path, link, what):
    """The project's validation settings make a link to a missing page or anchor fail the strict build."""
    docs = {"index.md": f"# Home\n\nSee [other](other.md#a-heading) and {link}.\n",
            "other.md": "# Other\n\n## A heading\n"}
    proc = _mini_site(tmp_path / "broken", docs, api=False)
    assert proc.returncode != 0 and what in proc.stderr, proc.stderr[-3000:]
    docs["index.md"] = "# Home\n\nSee [other](other.md#a-heading).\n"
    proc = _mini_site(tmp_path / "fixed", docs, api=False)
    assert proc.returncode == 0, proc.stderr[-3000:]  # the same site without the broken link builds


def test_links_are_chosen_from_autorefs_maps_without_asking_for_a_url(tmp_path):
    """Choosing a target only looks identifiers up: autorefs' URL lookup warns when an alias is documented twice."""
    roles = _roles()
    doc = _load(tmp_path, roles)["sub.Thing"].docstring.value

    class Maps:
        _primary_url_map = {"rolespkg.sub.Base": ["api/#rolespkg.sub.Base"]}
        _secondary_url_map = {"rolespkg.sub.LIMIT": ["api/a/#x", "api/b/#x"]}  # two URLs: get_item_url would warn

        def get_item_url(self, identifier):
            raise AssertionError("get_item_url called")

    page = _page(doc)
    counts = roles.resolve_markers([page], Maps())
    assert '<autoref identifier="rolespkg.sub.LIMIT"><code>LIMIT</code></autoref>' in page.content
    assert '<autoref identifier="rolespkg.sub.Base"><code>Its base</code></autoref>' in page.content
    assert '<autoref identifier="rolespkg.sub.Base"><code>reset</code></autoref>' in page.content  # Base.reset: not documented
    assert counts["linked"] == 3
