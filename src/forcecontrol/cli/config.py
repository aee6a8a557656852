"""``forcecontrol import-config FILE`` and ``forcecontrol export-config FILE``: the vendor/ROS controllers' own files.

``import-config`` reads a controller's configuration unmodified (ros2_controllers admittance
YAML, FZI compliance/force YAML, franka_ros YAML or ``compliance_param.cfg``, URScript
``force_mode`` lines; :mod:`forcecontrol.realarm.conventions.configs`) and prints the equivalent
scenario (TOML) for ``forcecontrol run``. ``export-config`` writes parameters back into the file in
its own format: only the changed values' characters change, comments and unknown keys stay.
Everything the reader did not read, mapped or defaulted is said on stderr and in ``--json``.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated, Any

import typer

from .app import _fail, err_console, print_json, say_note

__all__ = ["import_config_command", "export_config_command"]

KindOption = Annotated[str | None, typer.Option(
    "--type",
    help="ros2-admittance, fzi-compliance, fzi-force, franka-cartesian-impedance or ur-force-mode (default: from the keys)",
)]
SectionOption = Annotated[str | None, typer.Option(help="the controller's section of a YAML file holding several")]
JsonOption = Annotated[bool, typer.Option("--json", help="print one JSON object instead of the text")]


def import_config_command(
    file: Annotated[Path, typer.Argument(help="the controller's configuration file")],
    kind: KindOption = None,
    section: SectionOption = None,
    inline: Annotated[bool, typer.Option(help="write the parameters as keys instead of naming the file")] = False,
    json_out: JsonOption = False,
) -> None:
    """Print the scenario (TOML) that runs a vendor or ROS controller from its own configuration file."""
    from ..errors import ForceControlError
    from ..realarm.conventions.configs import read_config
    from ..scenarios.parts_vendor import check_vendor_parameters, scenario_toml

    try:
        cfg = read_config(file, kind, section)
        check_vendor_parameters(cfg)  # values the controller refuses: an error here, not a scenario that cannot run
        text = scenario_toml(cfg, inline=inline)
    except ForceControlError as exc:
        _fail(exc)
    if json_out:
        print_json({"kind": cfg.kind, "source": cfg.source, "section": cfg.section, "rate": cfg.rate,
                    "parameters": cfg.parameters, "notes": cfg.notes, "scenario": text})
        return
    for note in cfg.notes:
        say_note(note)
    sys.stdout.write(text)


def _parse_sets(items: list[str] | None) -> dict[str, Any]:
    """``NAME=VALUE`` pairs, the value read as TOML (``0.3``, ``[1.0, 2.0]``, ``true``)."""
    import tomllib

    from ..errors import ParameterError

    out: dict[str, Any] = {}
    for item in items or []:
        name, sep, value = item.partition("=")
        if not sep or not name.strip():
            raise ParameterError(f"--set must be NAME=VALUE (e.g. error_scale=0.3, mass=[5.5, 6.6, 7.7, 8.8, 9.9, 10.1]); "
                                 f"got {item!r}")
        try:
            out[name.strip()] = tomllib.loads(f"v = {value.strip()}")["v"]
        except tomllib.TOMLDecodeError as exc:
            raise ParameterError(
                f"--set {name.strip()}: the value must be a number, a list or true/false; got {value!r}"
            ) from exc
    return out


def _scenario_parameters(path: Path) -> dict[str, Any]:
    """The parameters a scenario's ``[controller]`` table gives (its keys other than type/config/section)."""
    import tomllib

    from ..errors import ParameterError

    try:
        table = tomllib.loads(path.read_text(encoding="utf-8")).get("controller", {})
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise ParameterError(f"--scenario {path}: cannot be read as TOML: {exc}") from exc
    if not isinstance(table, dict):
        raise ParameterError(f"--scenario {path}: [controller] must be a table")
    return {k: v for k, v in table.items() if k not in ("type", "config", "section")}


def export_config_command(
    file: Annotated[Path, typer.Argument(help="the controller's configuration file to write the parameters into")],
    set_: Annotated[list[str] | None, typer.Option(
        "--set", help="NAME=VALUE (library names, e.g. error_scale=0.3); repeatable")] = None,
    scenario: Annotated[Path | None, typer.Option(help="take the parameters of this scenario's [controller] table")] = None,
    out: Annotated[Path | None, typer.Option(help="write here (default: print the file's new text)")] = None,
    in_place: Annotated[bool, typer.Option("--in-place", help="rewrite FILE itself")] = False,
    force: Annotated[bool, typer.Option("--force", help="overwrite an existing --out file")] = False,
    kind: KindOption = None,
    section: SectionOption = None,
    json_out: JsonOption = False,
) -> None:
    """Write tuned parameters back into a controller's own configuration file, in its format (comments kept)."""
    from ..errors import ForceControlError, OutputError, ParameterError
    from ..realarm.conventions.configs import read_config
    from ..scenarios.parts_vendor import check_vendor_parameters

    try:
        cfg = read_config(file, kind, section)
        changes = {**(_scenario_parameters(scenario) if scenario is not None else {}), **_parse_sets(set_)}
        if not changes:
            raise ParameterError("nothing to write: give --set NAME=VALUE or --scenario FILE")
        skipped = sorted(k for k in changes if k not in cfg.writable())
        for k in skipped:  # a scenario key the format cannot hold (e.g. virtual_mass, soft_start)
            changes.pop(k)
        if skipped and scenario is None:
            raise ParameterError(f"cannot write {skipped[0]!r} to a {cfg.kind} file; writable: {', '.join(cfg.writable())}")
        text = cfg.write(**changes)
        check_vendor_parameters(read_config(file, kind, section, text=text))  # never write values the controller refuses
        target = file if in_place else out
        if target is not None:
            if in_place and out is not None:
                raise ParameterError("give --out or --in-place, not both")
            if not in_place and target.exists() and not force:
                raise OutputError(f"{target} exists; use --force to overwrite it, or --in-place to rewrite {file}")
            target.write_text(text, encoding="utf-8")
    except (ForceControlError, OSError) as exc:
        _fail(exc)
    changed = [k for k in changes if changes[k] != cfg.parameters.get(k)]
    notes = [f"{k}: not a key of the {cfg.kind} format, not written" for k in skipped]
    if json_out:
        print_json({"kind": cfg.kind, "source": cfg.source, "written": str(target) if target is not None else None,
                    "changed": changed, "notes": notes, **({"text": text} if target is None else {})})
        return
    for n in notes:
        say_note(n)
    err_console.print(f"changed: {', '.join(changed) or 'nothing (the values equal the file’s)'}", highlight=False, markup=False)
    if target is None:
        sys.stdout.write(text)
    else:
        err_console.print(f"written: {target}", highlight=False, markup=False)
