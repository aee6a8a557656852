"""End-to-end journeys (issue 27): the README's and the getting-started page's commands verbatim, and
``forcecontrol run NAME`` (table and ``--json``, figures on) for every built-in scenario, checked against
the book's printed numbers and closed forms; ``list``, ``show``, ``schema`` and ``task`` as a user types them.

Each command runs as a subprocess (the ``forcecontrol`` console script) in a temporary folder with its
defaults. The other journeys: test_journeys_files.py (report, design, replay, compare-trace, convert,
calibrate, compare) and test_journeys_tune.py (tune in a browser).
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import pytest

try:
    import tomllib
except ImportError:  # Python 3.10
    import tomli as tomllib

from journeys_helpers import assert_figure, fenced_commands, forcecontrol, number, png_size, rich_tables, shell

ROOT = Path(__file__).resolve().parents[1]
SCENARIOS = [
    "example-9.1", "example-9.2", "example-9.3", "example-9.4", "hybrid-rigid-plane", "impact-safety", "impact",
    "panda-admittance-contact", "panda-peg-in-hole", "panda-table-line", "problem-9.10", "problem-9.3", "variable-stiffness",
    "arm-circle-contour", "arm-unknown-circle", "arm-unknown-circle-parallel", "panda-sphere", "servo-admittance",
    "ur5-admittance-servo", "panda-unknown-cylinder", "panda-unknown-sphere", "panda-wipe-heightfield", "panda-spiral-search",
]
R2 = math.sqrt(0.5)


def _k(label: str) -> float:
    """The plane stiffness named in a case label ('k_x = 1e4 N/m')."""
    return float(re.search(r"k_x = (\S+) N/m", label).group(1))


def _compliance(label: str) -> dict[str, float]:
    """Example 9.1's closed forms (9.22)-(9.23): k_x = 1e3 N/m, x_r = 1, x_d = [1.1, 0.1], k_Px = ratio * k_x."""
    k_p = float(label.split("=")[1]) * 1e3
    return {"fx": k_p * 1e3 / (k_p + 1e3) * 0.1, "x": (k_p * 1.1 + 1e3 * 1.0) / (k_p + 1e3), "y": 0.1}


#: the book's printed values and the chapter's closed forms, per scenario and case label: a value (0.5 %, or 1e-3
#: absolute near zero) or (value, absolute tolerance); written from the chapter, not from the scenarios' [expected].
BOOK = {
    "example-9.1": _compliance,
    # Example 9.2: 200 N / 2.00 cm on k = 1e4 N/m, 71.4 N / 7.14 cm on k = 1e3 N/m; y settles at y_d = 0.1
    "example-9.2": lambda lab: ({"fx": 200.0, "x": 1.02, "y": 0.1} if _k(lab) == 1e4 else {"fx": 71.4, "x": 1.0714, "y": 0.1}),
    # Example 9.3: f_d = 10 N on every scheme, x = x_r + f_d / k; the parallel scheme also holds y_d = 0.1
    "example-9.3": lambda lab: {"fx": 10.0, "x": 1.0 + 10.0 / _k(lab), "fy": 0.0, "y": 0.1 if "parallel" in lab else 0.0},
    # Example 9.4 / Problem 9.10 / Problem 9.3 / Sect. 9.7.2: 50 N into the pi/4 plane, h_e = 50 [1, -1] / sqrt(2)
    "example-9.4": lambda lab: {"fx": 50 * R2, "fy": -50 * R2},
    "problem-9.10": lambda lab: {"fx": 50 * R2, "fy": -50 * R2},
    "problem-9.3": lambda lab: {"fx": 50 * R2, "fy": -50 * R2},
    "hybrid-rigid-plane": lambda lab: {"fx": 50 * R2, "fy": -50 * R2},
    # direct force control with f_d = 10 N (the documented gains settle there; a 0.2 N ripple is left on the stiff plane)
    "impact": lambda lab: {"fx": (10.0, 0.2)} if "documented" in lab or "re-designed" in lab else {},
    "impact-safety": lambda lab: {"fx": (10.0, 0.2)} if "documented" in lab else {},
    # Panda: 20 N pressed down on the table; springs in series k K/(k + K) * 2 cm = 16.7 N down; a peg without load
    "panda-table-line": lambda lab: {"f_z": -20.0},
    "panda-admittance-contact": lambda lab: {"f_z": -5e3 * 1e3 / 6e3 * 0.02},
    "panda-peg-in-hole": lambda lab: {"fx": (0.0, 0.05), "fy": (0.0, 0.05)},  # from 10 N (2 mm x 5000 N/m) to 0
    "variable-stiffness": lambda lab: {},
    # a disc (R = 0.2 m, k = 1e4 N/m) traced at r_d = 0.19 m with k_p = 2500 N/m, stopped at 45 deg: the tip at
    # r = (k R + k_p r_d)/(k + k_p) = 0.198 m, 20 N towards the centre (frictionless)
    "arm-circle-contour": lambda lab: ({"x": 1.0 + 0.198 * R2, "y": 0.35 + 0.198 * R2, "fx": -20 * R2, "fy": -20 * R2}
                                       if lab == "frictionless" else {}),
    # still tracing at the end (no settled point): its own checks (the normal-force error of the analysis) must pass
    "arm-unknown-circle": lambda lab: {},
    # the parallel scheme (9.48) in the estimated frame, still tracing at the end: its own checks must pass
    "arm-unknown-circle-parallel": lambda lab: {},
    # a ball (R = 0.2 m, k = 1e4 N/m) traced at r_d = 0.189 m with k_p = 1000 N/m, stopped at 60 deg in the x-z plane:
    # 10 N towards the centre, f_x = -10 cos 60 deg
    "panda-sphere": lambda lab: {"fx": (-5.0, 0.01)},
    # still tracing at the end (surface unknown): their own check, the 10 N within 1 N, must pass
    "panda-unknown-cylinder": lambda lab: {},
    "panda-unknown-sphere": lambda lab: {},
    # still wiping at the end (its own check: 10 N within 1 N); the search's own checks: the hole found where it is, or not
    "panda-wipe-heightfield": lambda lab: {},
    "panda-spiral-search": lambda lab: {},
    # springs in series behind the servo: k K_Pt/(k + K_Pt) * 1 cm (the 8000 N/m case bounces: no settled value)
    "servo-admittance": lambda lab: {"fx": 2000 * 1000 / 3000 * 0.01} if lab.startswith("k = 2000") else {},
    "ur5-admittance-servo": lambda lab: {"f_z": -3000 * 1000 / 4000 * 0.01},
}
# the cases whose contact force still swings at the end (a `not-settled` warning): a bounce, a loop beyond its limit,
# the tank's slowly decaying oscillation; every other case settles or only ripples along its curve
NOT_SETTLED = {
    "impact": ["naive gains: Example 9.3's k_D = 500 N s/m (ζ = 0.10)"],
    "servo-admittance": ["k = 8000 N/m (beyond the limit: bounces)"],
    "variable-stiffness": ["same schedule with an energy tank"],
}
COLUMN = {"x": "x [m]", "y": "y [m]", "fx": "f_x [N]", "fy": "f_y [N]", "f_z": "f_z [N]"}


# ----------------------------------------------------------------------------- the README's lines, verbatim


def _first_screen(text: str) -> str:
    """The README's first screen: everything above its first horizontal rule."""
    return text.split("\n---\n", 1)[0]


def test_ci_runs_the_readmes_test_line_verbatim():
    """`.ci/run` ends with the README first screen's test line, character for character, and runs nothing after it
    (what it does before, such as byte-compiling the sources, is installation)."""
    screen = _first_screen((ROOT / "README.md").read_text(encoding="utf-8"))
    line = screen.split("# 2. run the tests", 1)[1].splitlines()[1]
    assert line.startswith("pip install -e") and "pytest" in line
    commands = [s for s in (ROOT / ".ci" / "run").read_text(encoding="utf-8").splitlines()
                if s.strip() and not s.lstrip().startswith("#")]
    assert commands[-1] == line


def test_readme_first_screen_and_getting_started_commands_run_twice(tmp_path):
    """The README's first screen and docs/getting-started.md: their forcecontrol lines run verbatim, twice, exit 0;
    the first run writes the PNG and prints the book's 71.4 N / 7.14 cm and 200 N / 2.00 cm, a re-run keeps it and succeeds."""
    readme = fenced_commands(_first_screen((ROOT / "README.md").read_text(encoding="utf-8")))
    started = fenced_commands((ROOT / "docs" / "getting-started.md").read_text(encoding="utf-8"))
    assert readme == ["forcecontrol run example-9.2"] and started == readme  # the journey below is the documented one
    png = tmp_path / "forcecontrol-out" / "example-9.2" / "example-9.2.png"
    first = shell(tmp_path, readme[0])
    assert_figure(png)
    rows = {r["case"]: r for r in rich_tables(first.stdout)[0]}
    assert number(rows["k_x = 1e3 N/m"]["f_x [N]"]) == pytest.approx(71.4, rel=5e-3)
    assert number(rows["k_x = 1e3 N/m"]["x [m]"]) - 1.0 == pytest.approx(0.0714, rel=5e-3)
    assert number(rows["k_x = 1e4 N/m"]["f_x [N]"]) == pytest.approx(200.0, rel=5e-3)
    assert number(rows["k_x = 1e4 N/m"]["x [m]"]) - 1.0 == pytest.approx(0.0200, rel=5e-3)
    assert "figure: forcecontrol-out/example-9.2/example-9.2.png" in first.stdout
    before = png.read_bytes()
    for n in (2, 3):  # the same line again, as a user re-runs it (here: the README's, then the getting-started page's)
        again = shell(tmp_path, started[0])
        assert png.read_bytes() == before  # never overwritten
        moved = tmp_path / "forcecontrol-out" / f"example-9.2-{n}" / "example-9.2.png"
        assert_figure(moved)
        assert f"forcecontrol-out/example-9.2-{n}/example-9.2.png" in again.stdout
        assert f"this run writes in 'forcecontrol-out/example-9.2-{n}'" in again.stderr  # and it says so


def test_readme_stability_and_calibration_blocks(tmp_path):
    """The README's other blocks run verbatim: run variable-stiffness (the naive schedule pumps ~1634 N, the tank
    stays passive), design ... --out designed.toml (a scenario run then reads back), calibrate-plan and calibrate."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    lines = [c for c in fenced_commands(text) if not c.startswith("forcecontrol tune")]  # tune: test_journeys_tune.py
    assert "forcecontrol run variable-stiffness" in lines and any(c.startswith("forcecontrol design ") for c in lines)
    outs = {c: shell(tmp_path, c) for c in lines if c != "forcecontrol run example-9.2"}
    rows = {r["case"]: r for r in rich_tables(outs["forcecontrol run variable-stiffness"].stdout)[0]}
    assert number(rows["naive schedule (no tank)"]["peak |f| [N]"]) == pytest.approx(1634, rel=5e-3)
    assert number(rows["same schedule with an energy tank"]["peak |f| [N]"]) < 100
    assert_figure(tmp_path / "forcecontrol-out" / "variable-stiffness" / "variable-stiffness.png")
    designed = tmp_path / "designed.toml"
    assert tomllib.loads(designed.read_text(encoding="utf-8"))["controller"]["type"]
    run = forcecontrol(tmp_path, "run", "designed.toml", "--json")
    assert json.loads(run.stdout)["all_checks_pass"] is True
    # the un-highlighted calibration block: '$ forcecontrol ...' lines, on a readings file written like the README's
    from test_cli_calibrate import TRUE, _quaternion_csv

    block = re.search(r"```\n(\$ forcecontrol calibrate-plan.*?)```", text, flags=re.S).group(1)
    cal = [ln[2:].split("  #")[0].strip() for ln in block.splitlines() if ln.startswith("$ forcecontrol")]
    assert cal == ["forcecontrol calibrate-plan panda 8 --out poses.csv", "forcecontrol calibrate readings.csv"]
    _quaternion_csv(tmp_path / "readings.csv")
    plan, calib = (shell(tmp_path, c) for c in cal)
    assert len((tmp_path / "poses.csv").read_text().strip().splitlines()) == 9  # a header and 8 poses
    params = {r["parameter"]: r for r in rich_tables(calib.stdout)[0]}
    assert number(params["mass"]["value"]) == pytest.approx(TRUE["mass"], abs=4 * number(params["mass"]["± std"]))
    assert "condition number of the poses" in calib.stdout and "condition number" in plan.stdout


# ----------------------------------------------------------------------------- run NAME, every built-in scenario


@pytest.fixture(scope="session")
def journey_dirs(tmp_path_factory):
    """One folder where the scenarios run with their table, one where they run with --json (shared by the session)."""
    return tmp_path_factory.mktemp("journey-table"), tmp_path_factory.mktemp("journey-json")


def test_list_shows_every_scenario_the_journeys_run(tmp_path):
    """`forcecontrol list` names exactly the scenarios journeyed here (a new scenario must get its journey)."""
    rows = rich_tables(forcecontrol(tmp_path, "list").stdout)[0]
    assert sorted(r["name"] for r in rows if r["name"]) == sorted(SCENARIOS)


def _figures(stdout: str, cwd: Path) -> list[Path]:
    """The figure files a run printed ('figure: PATH', 'figure:NAME: PATH')."""
    return [cwd / line.split(": ", 1)[1] for line in stdout.splitlines() if line.startswith("figure")]


def _agree(cell: str, value: float) -> bool:
    """A printed cell equals a JSON value to the printed decimals (half a unit of the last digit)."""
    decimals = len(cell.split(".")[1]) if "." in cell else 0
    return abs(number(cell) - value) <= 0.5 * 10.0 ** -decimals + 1e-12 * abs(value)


@pytest.mark.parametrize("name", SCENARIOS)
def test_run_every_scenario_table_json_figures_and_the_book(name, journey_dirs):
    """`run NAME` and `run NAME --json` with figures on: exit 0, no traceback, no empty line on stderr (a progress bar's
    leftover), valid PNGs of a sensible size, every check ok, the table equal to the JSON to its printed digits, and the
    settled values equal to the book's."""
    table_dir, json_dir = journey_dirs
    table = forcecontrol(table_dir, "run", name)
    doc = json.loads(forcecontrol(json_dir, "run", name, "--json").stdout)
    assert all(line.strip() for line in table.stderr.splitlines()), f"an empty line on stderr: {table.stderr!r}"
    figures = _figures(table.stdout, table_dir)
    assert figures and all(p.parent == table_dir / "forcecontrol-out" / name for p in figures)
    for p in figures:
        assert_figure(p)
    json_figures = [json_dir / v for k, v in doc["files"].items() if k.startswith("figure")]
    assert sorted(p.name for p in json_figures) == sorted(p.name for p in figures)
    assert all(png_size(p) == png_size(table_dir / "forcecontrol-out" / name / p.name) for p in json_figures)
    assert doc["scenario"] == name and doc["all_checks_pass"] is True
    for case in doc["cases"]:  # every number of a case has its unit in the map (flags and labels aside)
        values = {**case["settled"], **{f"analysis.{k}": v for k, v in (case["analysis"] or {}).items()}}
        numbers = [k for k, v in values.items() if isinstance(v, int | float) and not isinstance(v, bool)]
        flags = {"bounced", "hole_found"}  # yes/no as 1/0: no unit
        assert not [k for k in numbers if k not in doc["units"] and k.split(".")[-1] not in flags], (name, doc["units"])
    assert all(ch["ok"] for c in doc["cases"] for ch in c["checks"])
    swinging = [c["label"] for c in doc["cases"] if any(w["kind"] == "not-settled" for w in c["warnings"])]
    assert swinging == NOT_SETTLED.get(name, []), swinging
    printed = " ".join(table.stdout.split())  # the warning lines as the terminal wrapped them
    assert all(" ".join(f"{label}: has not settled".split()) in printed for label in swinging)
    settled, book = rich_tables(table.stdout)[0], rich_tables(table.stdout)[1] if doc["cases"][0]["checks"] else []
    assert [r["case"] for r in settled] == [c["label"] for c in doc["cases"]]
    assert len(book) == sum(len(c["checks"]) for c in doc["cases"]) and all(r[""] == "ok" for r in book)
    for row, case in zip(settled, doc["cases"]):
        s = case["settled"]
        pairs = [("t_end [s]", case["final"]["t"]), ("x [m]", s["x"]), ("y [m]", s["y"]), ("f_x [N]", s["fx"]),
                 ("f_y [N]", s["fy"]), ("peak |f| [N]", case["peak_contact_force_norm"])]
        if "fz" in s:  # a 6-D case: the table shows z and f_z too
            pairs.append(("f_z [N]", s["fz"]))
            assert number(row["z [m]"]) == pytest.approx(case["final"]["tip_position"][2], abs=1e-3)  # settled, at rest
        for col, value in pairs:
            assert _agree(row[col], value), f"{name} / {case['label']}: table {col} = {row[col]}, --json {value}"
        assert row["engine"] == case["engine"]
        for key, want in BOOK[name](case["label"]).items():
            want, tol = want if isinstance(want, tuple) else (want, 1e-3)
            got = s["fz"] if key == "f_z" else s[key]
            assert got == pytest.approx(want, rel=5e-3, abs=tol), f"{name} / {case['label']}: {key}"
            assert number(row[COLUMN[key]]) == pytest.approx(want, rel=5e-3, abs=max(tol, 2e-3))


# ----------------------------------------------------------------------------- show, schema, task


def test_show_gives_a_template_that_runs_as_the_builtin(tmp_path):
    """`show NAME` prints TOML for every scenario; `show example-9.2 > mine.toml`, renamed, runs to the book's values."""
    for name in SCENARIOS:
        doc = tomllib.loads(forcecontrol(tmp_path, "show", name).stdout)
        assert doc["name"] == name and doc["duration"] > 0
    shell(tmp_path, "forcecontrol show example-9.2 > mine.toml")
    text = (tmp_path / "mine.toml").read_text(encoding="utf-8").replace('name = "example-9.2"', 'name = "mine"', 1)
    (tmp_path / "mine.toml").write_text(text, encoding="utf-8")
    out = forcecontrol(tmp_path, "run", "mine.toml")
    rows = {r["case"]: r for r in rich_tables(out.stdout)[0]}
    assert number(rows["k_x = 1e3 N/m"]["f_x [N]"]) == pytest.approx(71.4, rel=5e-3)
    assert_figure(tmp_path / "forcecontrol-out" / "mine" / "mine.png")


def test_schema_table_and_json(tmp_path):
    """`schema` lists the tables and keys of the README's scenario file; `schema --json` is a JSON schema with them."""
    text = forcecontrol(tmp_path, "schema").stdout
    for key in ("duration", "sample_time", "start_position", "stiffness", "settle_window", "[robot]"):
        assert key in text, key
    assert 'type = "impedance"' in text and 'type = "elastic-plane"' in text
    schema = json.loads(forcecontrol(tmp_path, "schema", "--json").stdout)
    assert {"name", "duration", "sample_time"} <= set(schema["properties"]) and "$defs" in schema


def _units(columns: list[list[float]]) -> list[int]:
    """The row of the 1 in each column of a selection matrix made of unit columns."""
    out = []
    for j in range(len(columns[0])):
        col = [row[j] for row in columns]
        assert sorted(col) == [0.0] * (len(col) - 1) + [1.0]
        out.append(col.index(1.0))
    return out


# the chapter's S_f and S_v (after Tables 9.1-9.3): the rows (0-5: f_x f_y f_z mu_x mu_y mu_z) of their unit columns
TASKS = {"sliding-on-plane": ([2, 3, 4], [0, 1, 5]), "peg-in-hole": ([0, 1, 3, 4], [2, 5]),
         "turning-crank": ([0, 2, 3, 4], [1, 5])}


def test_task_tables_are_the_books(tmp_path):
    """`task list`, then `task NAME` for Tables 9.1-9.3 and Example 9.4: S_f and S_v as printed in the chapter."""
    names = [r["name"] for r in rich_tables(forcecontrol(tmp_path, "task", "list").stdout)[0]]
    assert set(TASKS) | {"example-9.4", "problem-9.10"} <= set(names)
    for name, (s_f, s_v) in TASKS.items():
        table = forcecontrol(tmp_path, "task", name)
        assert "Natural constraints" in table.stdout and "S_f =" in table.stdout
        doc = json.loads(forcecontrol(tmp_path, "task", name, "--json").stdout)
        assert _units(doc["S_f"]) == s_f and _units(doc["S_v"]) == s_v, name
    base = json.loads(forcecontrol(tmp_path, "task", "example-9.4", "--frame", "base", "--json").stdout)
    # Example 9.4: S_f = R_c S_f^c = [-1, 1] / sqrt(2), S_v = [1, 1] / sqrt(2)
    assert [r[0] for r in base["S_f"]] == pytest.approx([-R2, R2]) and [r[0] for r in base["S_v"]] == pytest.approx([R2, R2])
