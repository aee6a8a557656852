"""``--set KEY=VALUE``: change a scenario key on the command line (``run``, ``analyze``, ``sweep``).

VALUE is read as a TOML value (``[5000, 5000]``, ``2.5``, ``true``, ``"up"``); a bare word that is
not TOML (``up``) is read as that string. The key is a dotted path of the scenario's tables, as in
a ``[[case]]`` table (``controller.stiffness``, ``environment.stiffness``, ``duration``). The
change is applied to every case and validated like a scenario file key
(:meth:`forcecontrol.scenarios.Scenario.with_`): an unknown key or a bad value is an error naming it.
"""

from __future__ import annotations

import re
import sys
from typing import Annotated, Any

import typer

from ..errors import ParameterError

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

__all__ = ["SetOption", "parse_sets", "apply_sets"]

SetOption = Annotated[list[str] | None, typer.Option(  # noqa: UP007 - typer needs Optional
    "--set", metavar="KEY=VALUE",
    help="change a scenario key in every case, e.g. --set controller.stiffness=[5000,5000] or --set duration=2 "
         "(VALUE is a TOML value, a bare word a string; repeatable; checked like a key of the file)",
)]

_KEY = re.compile(r"^[A-Za-z_][A-Za-z0-9_-]*(\.[A-Za-z_][A-Za-z0-9_-]*)*$")
_BARE = re.compile(r"^[A-Za-z_][A-Za-z0-9_.+-]*$")
MAX_SET_LENGTH = 10_000  # characters of one --set (a gain matrix fits)


def parse_sets(items: list[str] | None) -> dict[str, Any]:
    """``{"controller.stiffness": [5000, 5000], ...}`` from ``--set`` options, in the order given.

    Raises:
        ParameterError: an option without ``=``, a key that is not a dotted name, a key given twice,
            a value that is not a TOML value, or an option longer than :data:`MAX_SET_LENGTH`.
    """
    out: dict[str, Any] = {}
    for item in items or []:
        if len(item) > MAX_SET_LENGTH:
            raise ParameterError(f"--set must be at most {MAX_SET_LENGTH} characters; got {len(item)}")
        key, eq, text = item.partition("=")
        key, text = key.strip(), text.strip()
        if not eq or not key:
            raise ParameterError(f"--set must be KEY=VALUE (e.g. controller.stiffness=[5000,5000]); got {item!r}")
        if not _KEY.match(key):
            raise ParameterError(f"--set key must be a dotted name of the scenario's tables (e.g. controller.stiffness); "
                                 f"got {key!r}")
        if key in out:
            raise ParameterError(f"--set {key} is given twice ({out[key]!r} and {text!r}); give it once")
        out[key] = _value(key, text)
    return out


def _value(key: str, text: str) -> Any:
    if "\n" in text or "\r" in text:
        raise ParameterError(f"--set {key}: VALUE must be one line; got {text!r}")
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError as exc:
        if _BARE.match(text) and text not in ("true", "false", "inf", "nan"):
            return text  # a bare word: the string (robot.elbow=down)
        raise ParameterError(f"--set {key}: VALUE must be a TOML value (a number, true/false, \"text\", [a, b] or "
                             f"[[a, b], [c, d]]); got {text!r} ({exc})") from None


def apply_sets(scn: Any, sets: dict[str, Any]) -> tuple[Any, list[str]]:
    """The scenario with ``sets`` applied to every case (validated) and notes on what that replaced.

    A key that a case's own ``[[case]]`` table sets is replaced for that case too: the note names
    the cases (their label may no longer describe them).

    Raises:
        ScenarioError: a key names no table or key of a case, or a value is invalid (from ``Scenario.with_``).
    """
    if not sets:
        return scn, []
    notes = []
    for key in sets:
        hit = [c.label for c in scn.cases if any(o == key or o.startswith(key + ".") for o in c.overrides)]
        if hit:
            notes.append(f"--set {key} replaces the value the [[case]] table of {', '.join(repr(h) for h in hit)} sets "
                         "(the label may no longer describe the case)")
    from ..errors import ScenarioError

    try:
        return scn.with_(sets), notes
    except ScenarioError as exc:
        culprit = _culprit(scn, sets) if len(sets) > 1 else next(iter(sets))
        raise ScenarioError(f"--set {culprit}={_toml(sets[culprit])}: {exc}") from None


def _culprit(scn: Any, sets: dict[str, Any]) -> str:
    """The first key whose change alone is refused (else the last: the keys are refused together)."""
    from ..errors import ScenarioError

    for key, value in sets.items():
        try:
            scn.with_({key: value})
        except ScenarioError:
            return key
    return list(sets)[-1]


def _toml(value: Any) -> str:
    import json

    return json.dumps(value) if not isinstance(value, str) else repr(value)
