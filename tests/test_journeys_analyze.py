"""Journeys of ``forcecontrol analyze`` on every built-in scenario, as a user runs them (subprocesses).

For each scenario ``forcecontrol list`` shows: ``analyze NAME`` (the table), ``analyze NAME --json``
and ``analyze NAME --verify`` exit 0 with no traceback; the table's numbers are the JSON's (to the
table's 6 significant digits); with ``--verify`` every case shows a verification or says why not.
"""

from __future__ import annotations

import json
import math
import os
import re
import subprocess

import pytest

import cli_server
from forcecontrol.scenarios import list_scenarios

SCENARIOS = sorted(list_scenarios())


def _analyze(*args: str) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "PYTHONIOENCODING": "utf-8", "COLUMNS": "200"}
    return cli_server.run(["analyze", *args], env=env, module=True, timeout=600)


def _ok(proc: subprocess.CompletedProcess[str]) -> None:
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "Traceback" not in proc.stderr, proc.stderr[-3000:]


def parse_tables(text: str) -> list[tuple[list[str], list[list[str]]]]:
    """The rich tables of a command's output: (header cells, rows of cells); a row wrapped over
    several lines is joined back (its continuation lines have an empty first cell)."""
    tables: list[tuple[list[str], list[list[str]]]] = []
    for line in text.splitlines():
        if line.startswith("┃"):
            tables.append(([c.strip() for c in line.strip("┃").split("┃")], []))
        elif line.startswith("│") and tables:
            cells = [c.strip() for c in line.strip("│").split("│")]
            rows = tables[-1][1]
            if rows and cells[0] == "":
                rows[-1] = [f"{a} {b}".strip() for a, b in zip(rows[-1], cells)]
            else:
                rows.append(cells)
    return tables


def _cell_matches(cell: str, value: object) -> bool:
    """A table cell shows the JSON value: None as '-', booleans yes/no, vectors [a, b], numbers to 6 digits."""
    if value is None:
        return cell == "-"
    if isinstance(value, bool):
        return cell == ("yes" if value else "no")
    if isinstance(value, list):
        parts = [p.strip() for p in cell.strip("[]").split(",")]
        return len(parts) == len(value) and all(_cell_matches(p, v) for p, v in zip(parts, value))
    shown = float(cell)
    return math.isclose(shown, float(value), rel_tol=1e-5, abs_tol=1e-300) or f"{float(value):.6g}" == cell


@pytest.mark.parametrize("name", SCENARIOS)
def test_analyze_table_and_json_agree(name):
    """`analyze NAME` and `analyze NAME --json` exit 0 without a traceback, and every analysis number of
    the JSON is the table's (each case's table, in order), expected analysis values included."""
    table, js = _analyze(name), _analyze(name, "--json")
    _ok(table)
    _ok(js)
    report = json.loads(js.stdout)
    tables = [t for t in parse_tables(table.stdout) if t[0][:3] == ["quantity", "predicted", "expected"]]
    assert len(tables) == len(report["cases"])
    for case, (_, rows) in zip(report["cases"], tables):
        if not case["analysis"]:  # says why, on the table and on stderr
            assert case["analysis_skipped"] and rows[0][0].startswith("(no analysis:")
            assert "no analysis applies" in " ".join(table.stderr.split())
            continue
        shown = {r[0].split(" [", 1)[0]: r for r in rows}  # the quantity without its unit ('stability_limit_x [N/m]')
        for key, value in case["analysis"].items():
            assert key in shown, (case["label"], key)
            assert _cell_matches(shown[key][1], value), (case["label"], key, shown[key][1], value)
        for c in case["checks"]:
            row = shown[c["metric"].split(".", 1)[1]]
            assert _cell_matches(row[2], c["expected"]) and row[4] == ("ok" if c["ok"] else "MISSED"), (row, c)


@pytest.mark.parametrize("name", SCENARIOS)
def test_analyze_verify_reports_every_case(name):
    """`analyze NAME --verify` exits 0 without a traceback; each case has a verification table whose
    rows all agree (or say 'differs' with a warning), or a line saying why it was not verified."""
    proc = _analyze(name, "--verify")
    _ok(proc)
    out = " ".join(proc.stdout.split())
    n_cases = len([t for t in parse_tables(proc.stdout) if t[0][:3] == ["quantity", "predicted", "expected"]])
    verifications = [t for t in parse_tables(proc.stdout) if t[0][:3] == ["quantity", "predicted", "simulated"]]
    not_verified = len(re.findall(r"not verified: ", out))
    assert len(verifications) + out.count("(no analysis:") == n_cases
    for _, rows in verifications:
        for r in rows:
            assert r[4] in ("agrees", "differs", "not verified"), r
            if r[4] == "differs":
                assert "warning:" in out
            if r[4] == "not verified":
                assert not_verified and "not verified" in " ".join(proc.stderr.split())
            if r[0].startswith("steady_"):
                float(r[1]), float(r[2])  # numbers on both sides
