"""--help prints every help string as written: bracketed units and ranges are text, not markup."""

from __future__ import annotations

import re

import typer.main
from typer.testing import CliRunner

from forcecontrol.cli import app

runner = CliRunner()
BRACKETED = re.compile(r"\[[^\[\]\n]+\]")


def _commands() -> list[tuple[list[str], object]]:
    root = typer.main.get_command(app)
    return [([], root)] + [([name], cmd) for name, cmd in sorted(root.commands.items())]


def _help_strings(cmd) -> list[str]:
    texts = [cmd.help or ""]
    texts += [getattr(p, "help", None) or "" for p in cmd.params]
    return texts


def test_every_bracketed_text_of_the_help_strings_is_in_help_output():
    """For every command, each '[...]' in its docstring and option help (units like [s], [deg], [dB], [kg]) is in --help."""
    checked = 0
    missing = []
    for args, cmd in _commands():
        res = runner.invoke(app, [*args, "--help"])
        assert res.exit_code == 0, (args, res.output)
        shown = "".join(res.stdout.split())  # wrapping may break lines anywhere there is a space or a hyphen
        for text in _help_strings(cmd):
            for item in BRACKETED.findall(text.partition("\f")[0]):
                checked += 1
                if "".join(item.split()) not in shown:
                    missing.append((" ".join(args) or "forcecontrol", item))
    assert checked > 15  # the source's help strings do hold units: the test looks at them
    assert not missing, missing


def test_design_help_keeps_the_range_and_units():
    """`design --help` says 'margin over [k_min, k_max]' and shows [s], [deg], [dB] and [kg] (issue 32's example)."""
    out = " ".join(runner.invoke(app, ["design", "--help"]).stdout.split())
    assert "margin over [k_min, k_max]" in out
    for unit in ("[s]", "[deg]", "[dB]", "[kg]", "[N/m]", "[Hz]", "[samples]"):
        assert unit in out, unit
