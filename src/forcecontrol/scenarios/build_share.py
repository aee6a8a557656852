"""Parts that the cases of one sweep row share when their tables are equal (``build_case(..., share=...)``)."""

from __future__ import annotations

import warnings
from collections.abc import Hashable, Iterator
from contextlib import contextmanager
from typing import Any

__all__ = ["PartShare", "warnings_shown"]


class PartShare:
    """Built parts that the cases of one sweep row share when their tables are equal (:func:`build_case`'s ``share``).

    The caller sets :attr:`keys` before each case: for ``"top"`` (the top-level values), ``"robot"``,
    ``"environment"``, ``"controller"`` and ``"reference"``, a hashable key equal for two cases exactly
    when that part of their configurations is equal (a sweep uses the swept values of that table).
    A part is then built (and its table checked) once per distinct key of its own table, of the
    top-level values and the robot, and of any other part its builder reads (the environment, for
    some controllers); a builder that reads the case's ``where`` or warns is not shared (its cases
    build their own). The parts returned are shared objects: only for a caller that copies what it
    needs from them and resets the controller per case (the sweep's compiled batch), never for
    cases that ``simulate()`` runs.
    """

    def __init__(self) -> None:
        self.keys: dict[str, Hashable] = {}
        self._store: dict[Any, Any] = {}


_NOT_SHARED = object()


class _Reads(dict):
    """A builder's context that notes which of its entries the builder read (every one, when it iterates or writes)."""

    def __init__(self, ctx: dict[str, Any]) -> None:
        super().__init__(ctx)
        self.read: set[str] = set()
        self._ctx = ctx

    def __setitem__(self, key: str, value: Any) -> None:  # a builder that writes the context: written through, not shared
        self._every()
        super().__setitem__(key, value)
        self._ctx[key] = value

    def __getitem__(self, key: str) -> Any:
        self.read.add(key)
        return super().__getitem__(key)

    def get(self, key: str, default: Any = None) -> Any:
        self.read.add(key)
        return super().get(key, default)

    def __contains__(self, key: object) -> bool:
        self.read.add(str(key))
        return super().__contains__(key)

    def _every(self) -> None:
        self.read.add("*")

    def __iter__(self):  # type: ignore[override]
        self._every()
        return super().__iter__()

    def keys(self):  # type: ignore[override]
        self._every()
        return super().keys()

    def values(self):  # type: ignore[override]
        self._every()
        return super().values()

    def items(self):  # type: ignore[override]
        self._every()
        return super().items()

    def copy(self) -> dict[str, Any]:  # type: ignore[override]
        self._every()
        return dict(super().items())


@contextmanager
def warnings_shown(swallow: bool = False) -> Iterator[list[Any]]:
    """The warnings shown inside the block (appended to the list it gives), or none shown with ``swallow``.

    The filters are left alone (``warnings.catch_warnings`` would reset every module's registry of warnings
    already shown, so a "default" warning said once before would be said again): only what passes the filters
    and the registries reaches ``warnings._showwarnmsg``, which is watched here. Without that hook (not CPython),
    every build counts as having said something.
    """
    said: list[Any] = []
    show = getattr(warnings, "_showwarnmsg", None)
    if show is None:  # pragma: no cover - CPython has it
        said.append(None)
        yield said
        return

    def watch(msg: Any) -> None:
        said.append(msg)
        if not swallow:
            show(msg)

    warnings._showwarnmsg = watch  # type: ignore[attr-defined]
    try:
        yield said
    finally:
        warnings._showwarnmsg = show  # type: ignore[attr-defined]


def _shared_part(share: PartShare | None, name: str, build: Any, ctx: dict[str, Any]) -> Any:
    """``build(ctx)`` (one of the case's parts), or the part already built for equal keys (:class:`PartShare`)."""
    if share is None:
        return build(ctx)
    keys, store = share.keys, share._store
    base = (name, keys["top"], keys["robot"], keys[name])
    deps = store.get(("reads", base))
    if deps is _NOT_SHARED:
        return build(ctx)
    if deps is not None:
        hit = store.get((base, tuple(keys[d] for d in deps)))
        if hit is not None:
            return hit
    seen = _Reads(ctx)
    with warnings_shown() as shown:  # a part whose build says something is not shared: its cases build (and say) their own
        part = build(seen)
    # ctx holds the robot, its q0 and the sample time (given by the "robot" and "top" keys), the case's
    # where (a builder that reads it may keep it) and the parts built before this one
    deps = tuple(sorted(seen.read - {"robot", "q0", "sample_time"}))
    if shown or "where" in deps or "*" in deps or any(d not in keys for d in deps):
        store[("reads", base)] = _NOT_SHARED
        return part
    store[("reads", base)] = deps
    store[(base, tuple(keys[d] for d in deps))] = part
    return part
