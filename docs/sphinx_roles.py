"""Sphinx-style cross-references in the docstrings (``:class:`X```) become links of the built site.

The docstrings of ``src/`` use Sphinx roles (``:class:``, ``:func:``, ``:meth:``, ``:attr:``,
``:mod:``, ``:data:``, ``:exc:``, ``:obj:``, ``:const:``, with the ``~`` and ``!`` prefixes and the
``Title <target>`` form); mkdocstrings renders Markdown, where such a role is literal text. Two steps
turn them into links, without touching the docstrings:

1. :class:`SphinxRoles`, a griffe extension (``mkdocs.yml``: ``extensions``), runs when griffe has
   loaded the package: each role of each docstring is resolved against the package, from the scope
   of the object that holds the docstring outwards (its members, its parents, its module, the
   package), and replaced by a marker ``<span class="fc-xref" data-fc-ids="a b c"><code>X</code></span>``
   whose ``data-fc-ids`` are the target's canonical path, then its parents up to its module.
2. :func:`resolve_markers` (called by ``hooks.py`` at ``on_env``, when every page is rendered and
   before autorefs fixes its links) turns each marker of a built page into an autorefs link to the
   first of those identifiers that the site documents (a private helper links to its class).

What cannot become a link is said, never dropped silently:

* a target that does not exist in the package (a typo, a renamed object): a **warning**, so
  ``mkdocs build --strict`` fails and names the page and the role;
* a target outside the package (``numpy.ndarray``, ``float``, the standard library): code text,
  counted (there is no inventory to link to offline);
* a target in the package that no API page documents (a private function, the CLI module): code
  text, counted, listed with ``mkdocs build --verbose``.

A role that reaches a built page unconverted (in a Markdown page, say) is a warning as well.
"""

from __future__ import annotations

import builtins
import html
import importlib.util
import logging
import re
import sys
from collections import Counter
from typing import Any

ROLES = ("class", "func", "meth", "attr", "mod", "data", "exc", "obj", "const")
#: A Sphinx role in a docstring (raw text: single back-quotes around the target).
ROLE = re.compile(r":(?:py:)?(?P<role>" + "|".join(ROLES) + r"):`(?P<target>[^`\n]+)`")
#: A Sphinx role as it looks once Markdown made its back-quotes a ``<code>`` element.
RENDERED_ROLE = re.compile(r":(?:py:)?(?:" + "|".join(ROLES) + r"):(?:<code>[^<]*</code>|`[^`]*`)")
MARKER = re.compile(
    r'<span class="fc-xref" data-fc="(?P<kind>[a-z]+)" data-fc-ids="(?P<ids>[^"]*)" '
    r'data-fc-note="(?P<note>[^"]*)">(?P<text>.*?)</span>'
)
PACKAGE = "forcecontrol"

log = logging.getLogger("mkdocs.plugins.forcecontrol.sphinx_roles")


# ---------------------------------------------------------------------------------------------- griffe side
def _split(target: str) -> tuple[str, str, bool]:
    """(display text, dotted name, link?) of a role's target, as Sphinx reads it."""
    target = target.strip()
    explicit = re.fullmatch(r"(?P<title>.+?)\s*<(?P<name>[^<>]+)>", target)
    if explicit:
        title, name = explicit["title"].strip(), explicit["name"].strip()
    else:
        title, name = None, target
    link = not name.startswith("!")
    name = name.lstrip("!")
    short = name.startswith("~")
    name = name.lstrip("~").removesuffix("()")
    text = title or (name.lstrip(".").rsplit(".", 1)[-1] if short else name)
    if title is None and target.lstrip("!~").endswith("()"):
        text += "()"
    return text, name, link


def _members(obj: Any) -> Any:
    """The members of ``obj``; a class's include the inherited ones (``:meth:`reset``` of a subclass)."""
    return obj.all_members if obj.is_class else obj.members


def _get(scope: Any, dotted: str) -> Any | None:
    """The member at ``dotted`` below ``scope`` (a griffe object), or None."""
    try:
        obj = scope
        for part in dotted.split("."):
            obj = _members(obj)[part]
        return obj
    except Exception:  # KeyError, AliasResolutionError, CyclicAliasError: not there
        return None


def _objects(obj: Any):
    """``obj`` and every object defined below it (aliases are documented where they point)."""
    yield obj
    for member in list(obj.members.values()):
        if not member.is_alias:
            yield from _objects(member)


class _Resolver:
    def __init__(self, pkg: Any) -> None:
        self.pkg = pkg
        self.by_suffix: dict[str, list[Any]] = {}
        for o in _objects(pkg):
            parts = o.path.split(".")
            for i in range(1, len(parts)):
                self.by_suffix.setdefault(".".join(parts[i:]), []).append(o)

    def find(self, name: str, where: Any) -> tuple[Any | None, str]:
        """``(object, path it was found at)`` that ``name`` means in the docstring of ``where``; ``(None, "")`` if none."""
        if name == self.pkg.name:
            return self.pkg, self.pkg.path
        if name.startswith(self.pkg.name + "."):
            return _get(self.pkg, name[len(self.pkg.name) + 1:]), name
        bare = name.lstrip(".")
        scope = where
        while scope is not None:  # the holder, its parents, its module, its package, the package
            found = _get(scope, bare)
            if found is not None:
                return found, f"{scope.path}.{bare}"
            scope = scope.parent
        matches = self.by_suffix.get(bare, [])
        return (matches[0], matches[0].path) if len(matches) == 1 else (None, "")

    def moved(self, name: str) -> Any | None:
        """The one object of the package named like the last part of ``name`` (a path that went stale), or None."""
        matches = self.by_suffix.get(name.rsplit(".", 1)[-1], [])
        return matches[0] if len(matches) == 1 else None

    def prefixes(self, path: str) -> tuple[list[str], list[str]]:
        """``path``'s parents (longest first) inside its module, and that module (a list of one, or empty)."""
        parts = path.split(".")
        out = []
        for i in range(len(parts) - 1, 0, -1):
            prefix = ".".join(parts[:i])
            obj = self.pkg if prefix == self.pkg.path else _get(self.pkg, prefix.partition(".")[2])
            if obj is None or _safe(lambda o=obj: o.is_module):
                return out, [prefix]
            out.append(prefix)
        return out, []

    def candidates(self, *paths: str) -> list[str]:
        """Identifiers to link to, best first: ``paths``, their parent classes, then their modules."""
        parents, modules = [], []
        for path in paths:
            p, m = self.prefixes(path)
            parents += p
            modules += m
        return list(dict.fromkeys([*paths, *parents, *modules]))


def _external(name: str, package: str) -> bool:
    """True for a name outside ``package``: a builtin, the standard library or another installed package."""
    first = name.lstrip(".").split(".", 1)[0]
    if first in vars(builtins) or first in sys.stdlib_module_names or first in {"np", "npt"}:
        return True
    try:
        return first != package and importlib.util.find_spec(first) is not None
    except (ImportError, ValueError):
        return False


def _safe(fn):
    try:
        return fn()
    except Exception:
        return None


def _enclosing_class(obj: Any) -> Any | None:
    while obj is not None and not obj.is_class:
        obj = obj.parent
    return obj


def convert(text: str, where: Any, resolver: _Resolver) -> str:
    """``text`` (a docstring) with each Sphinx role replaced by a marker (see the module's docstring)."""

    def marker(kind: str, ids: list[str], note: str, code: str) -> str:
        ids = list(dict.fromkeys(i for i in ids if i))
        return (f'<span class="fc-xref" data-fc="{kind}" data-fc-ids="{html.escape(" ".join(ids))}" '
                f'data-fc-note="{html.escape(note)}">{code}</span>')

    def sub(m: re.Match) -> str:
        shown, name, link = _split(m["target"])
        if not link:
            return f"`{shown}`"
        code = f"<code>{html.escape(shown)}</code>"
        note = f"{m['role']}:{name} in {where.path}"
        obj, path = resolver.find(name, where)
        if obj is not None:
            canonical = _safe(lambda: obj.canonical_path) or obj.path
            # an inherited member is documented (if at all) on the class the docstring names; anything else where it is defined
            first = (path, canonical) if _safe(lambda: obj.inherited) else (canonical, path)
            return marker("found", resolver.candidates(*first), note, code)
        if _external(name, resolver.pkg.name):
            return marker("external", [], note, code)
        obj = resolver.moved(name) if "." in name else None
        if obj is not None:  # a stale path: link where the object is now, and say so
            canonical = _safe(lambda: obj.canonical_path) or obj.path
            return marker("stale", resolver.candidates(canonical), f"{note} (now {canonical})", code)
        cls = _enclosing_class(where)
        if m["role"] == "attr" and "." not in name and cls is not None:
            # an instance attribute set outside __init__ (griffe cannot see it): the class documents it, if anything
            return marker("attribute", resolver.candidates(cls.path), note, code)
        return marker("missing", [], note, code)

    return ROLE.sub(sub, text)


try:
    from griffe import Extension
except ImportError:  # pragma: no cover - griffe comes with mkdocstrings[python]
    Extension = object  # type: ignore[assignment,misc]


class SphinxRoles(Extension):  # type: ignore[misc,valid-type]
    """Griffe extension: Sphinx roles of every docstring of ``package`` become link markers."""

    def __init__(self, package: str = PACKAGE) -> None:
        super().__init__()
        self.package = package

    def on_package(self, *, pkg: Any, **kwargs: Any) -> None:
        if pkg.name != self.package:
            return
        resolver = _Resolver(pkg)
        for obj in _objects(pkg):
            if obj.docstring is not None and ":" in obj.docstring.value:
                obj.docstring.value = convert(obj.docstring.value, obj, resolver)


# ---------------------------------------------------------------------------------------------- mkdocs side
def resolve_markers(pages, autorefs: Any) -> Counter:
    """Make the markers of ``pages`` autorefs links (or code text); warn on missing targets and stray roles.

    ``autorefs`` is the autorefs plugin after every page was rendered: an identifier it knows is
    documented somewhere on the site. Returns the counts by outcome: ``linked``, ``stale`` (linked
    where the object is now), ``external``, ``undocumented``, ``missing`` and ``stray``.
    """
    counts: Counter = Counter()
    undocumented: Counter = Counter()

    maps = [getattr(autorefs, name, None) for name in ("_primary_url_map", "_secondary_url_map")]

    def known(identifier: str) -> bool:
        if all(isinstance(m, dict) for m in maps):  # what autorefs itself looks in; asking get_item_url may warn
            return any(identifier in m for m in maps)
        try:
            autorefs.get_item_url(identifier)
        except KeyError:
            return False
        return True

    for page in pages:
        content = page.content
        if not content:
            continue
        where = page.file.src_uri

        def sub(m: re.Match, where: str = where) -> str:
            kind, text, note = m["kind"], m["text"], html.unescape(m["note"])
            if kind == "external":
                counts["external"] += 1
                return text
            if kind == "missing":
                counts["missing"] += 1
                log.warning("%s: cross-reference %s: no such object in the package", where, note)
                return text
            ids = html.unescape(m["ids"]).split()
            target = next((i for i in ids if known(i)), None) if kind != "attribute" else None
            if target is None:
                counts["undocumented"] += 1
                undocumented[note] += 1
                return text
            if kind == "stale":
                counts["stale"] += 1
                log.warning("%s: cross-reference %s names an old path; linked to its new place (fix the docstring)",
                         where, note)
            else:
                counts["linked"] += 1
            return f'<autoref identifier="{html.escape(target)}">{text}</autoref>'

        content = MARKER.sub(sub, content)
        for stray in RENDERED_ROLE.findall(content):
            counts["stray"] += 1
            log.warning("%s: Sphinx role %s reached the page unconverted", where, stray)
        page.content = content
    for note, n in sorted(undocumented.items()):
        log.debug("cross-reference %s (%d x): documented on no page, shown as code", note, n)
    log.info(
        "forcecontrol docs: cross-references: %d linked, %d linked from an old path, %d to other packages (code), "
        "%d to objects no page documents (code), %d missing",
        counts["linked"], counts["stale"], counts["external"], counts["undocumented"], counts["missing"],
    )
    return counts
