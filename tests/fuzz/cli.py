"""Kind (d): command-line options: one hostile value in an otherwise valid command line, for every subcommand.

Numbers: negative, zero, NaN, inf, 1e308, 401 digits, text. Files: missing, empty, ``/dev/null``,
``/dev/zero``, a FIFO, a folder, a user's existing file (``--out`` onto the sentinel tree's
``notes.csv`` or a folder that is not a sweep). Commands run in process (typer's CliRunner) except
those given a FIFO or ``/dev/zero``, which run as a subprocess with a timeout.
"""

from __future__ import annotations

import os
import random
from pathlib import Path

import numpy as np

from .core import Case, invoke

NUMBERS = ("-1", "0", "nan", "inf", "-inf", "1e308", "9" * 401, "abc", "")
BAD_NUMBERS = {"nan", "inf", "-inf", "1e308", "9" * 401, "abc", ""}
FILES = ("missing", "empty", "/dev/null", "/dev/zero", "fifo", "folder")

#: command -> (base argv with {files}, {numeric options: values for which a negative or zero is refused too})
COMMANDS = {
    "run": (["run", "short.toml", "--out", "out", "--json", "--no-figure"], {}),
    "analyze": (["analyze", "short.toml", "--json"], {}),
    "sweep": (["sweep", "short.toml", "-p", "sample_time=0.001,0.002", "--case", "1", "--out", "out/s.parquet", "--no-figure",
               "--workers", "1", "--json"], {"--workers": True, "--block-size": True, "--samples": False, "--seed": False}),
    "compare-trace": (["compare-trace", "short.toml", "trace.csv", "--out", "out", "--json"], {"--max-shift": False}),
    "replay": (["replay", "short.toml", "trace.csv", "--out", "out", "--json"], {}),
    "convert": (["convert", "trace.csv", "--from", "library", "--to", "ros-on", "--out", "out/c.csv", "--json"], {}),
    "calibrate": (["calibrate", "calib.csv", "--json"], {"--gravity": True, "--max-condition": True}),
    "calibrate-plan": (["calibrate-plan", "chapter-arm", "6", "--json"], {"--seed": False}),
    "design": (["design", "impedance", "--k-min", "1000", "--k-max", "10000", "--json"],
               {"--k-min": True, "--k-max": True, "--sample-time": True, "--delay": False, "--filter-cutoff": True,
                "--phase-margin": True, "--gain-margin": True, "--settling-time": True, "--damping-ratio": True,
                "--inertia": True, "--stiffness": True, "--arm-inertia": True}),
    "task": (["task", "list", "--json"], {"--time": False}),
    "report": (["report", "missing_run", "--out", "out/r.html"], {}),
    "show": (["show", "example-9.1"], {}),
}
#: the file argument of each command (its position in argv), replaced by a hostile file
FILE_ARGS = {"run": 1, "analyze": 1, "sweep": 1, "compare-trace": 2, "replay": 2, "convert": 1, "calibrate": 1, "report": 1}
#: commands whose --out is a file, pointed at the user's existing notes.csv
OUT_FILES = {"sweep": "out/s.parquet", "convert": "out/c.csv", "calibrate-plan": None, "design": None}


def _short_scenario() -> str:
    from forcecontrol.scenarios import scenario_source

    text = scenario_source("example-9.2").read_text(encoding="utf-8")
    return text.replace("duration = 4.0", "duration = 0.05", 1)


def _trace_csv() -> str:
    t = 0.001 * np.arange(60)
    rows = np.column_stack([t, np.full_like(t, np.pi / 3), np.full_like(t, -2 * np.pi / 3), 0 * t, 0 * t, 10 + 0 * t, 0 * t])
    return "t,q1,q2,qd1,qd2,fx,fy\n" + "".join(",".join(f"{v:.9g}" for v in r) + "\n" for r in rows)


def _calib_csv() -> str:
    rows = []
    for a in np.linspace(0, 2 * np.pi, 8, endpoint=False):
        c, s = np.cos(a), np.sin(a)
        f = -np.array([[c, s], [-s, c]]) @ np.array([0.0, -9.81]) * 1.2 + np.array([0.3, -0.2])
        rows.append(f"{a:.12g},{f[0]:.12g},{f[1]:.12g}")
    return "angle,fx,fy\n" + "\n".join(rows) + "\n"


def _prepare(hostile_file: str | None, name: str | None):
    scenario, trace, calib = _short_scenario(), _trace_csv(), _calib_csv()

    def prepare(d: Path):
        (d / "short.toml").write_text(scenario, encoding="utf-8")
        (d / "trace.csv").write_text(trace)
        (d / "calib.csv").write_text(calib)
        if hostile_file == "empty":
            (d / name).write_bytes(b"")
        elif hostile_file == "fifo":
            os.mkfifo(d / name)
        elif hostile_file == "folder":
            (d / name).mkdir()

    return prepare


def make_cases(seed: int, count: int, sentinel: Path) -> list[Case]:
    rng = random.Random(f"cli-{seed}")
    names = sorted(COMMANDS)
    out = []
    for i in range(count):
        cmd = names[i % len(names)]
        base, numeric = COMMANDS[cmd]
        argv = list(base)
        how = rng.choice(("number", "number", "file", "out", "garbage_flag"))
        hostile_file, fname, invalid, sub = None, None, False, how
        if how == "number" and numeric:
            opt = rng.choice(sorted(numeric))
            v = rng.choice(NUMBERS)
            argv += [opt, v] if v else [opt, v]
            # a seed of any size is a valid NumPy seed; a negative one is refused (not a silent acceptance either way)
            invalid = (v in BAD_NUMBERS and not (opt == "--seed" and v.isdigit())) or (numeric[opt] and v in ("-1", "0"))
            sub = f"{opt}={'<401 digits>' if len(v) > 20 else v}"
        elif how in ("file", "number") and cmd in FILE_ARGS:
            kind = rng.choice(FILES)
            pos = FILE_ARGS[cmd]
            suffix = Path(argv[pos]).suffix
            fname = {"missing": f"missing{suffix}", "empty": f"empty{suffix}", "fifo": f"pipe{suffix}",
                     "folder": f"folder{suffix}"}.get(kind, kind)
            argv[pos] = fname
            hostile_file, invalid, sub = kind, True, f"file:{kind}"
        elif how == "out" and (cmd in OUT_FILES or cmd in ("run", "compare-trace", "replay")):
            target = rng.choice((sentinel / "notes.csv", sentinel / "existing_folder"))
            if "--out" in argv:
                argv[argv.index("--out") + 1] = str(target)
            else:
                argv += ["--out", str(target)]
            sub = f"out:{target.name}"
            # a user's file is never overwritten; writing into an existing folder named by --out is allowed
            # for run/compare-trace/replay, so those are not checked against the sentinel
            if target.name == "existing_folder" and cmd in ("run", "compare-trace", "replay", "design"):
                argv[argv.index("--out") + 1] = "out"
                sub = "out:own"
        else:
            flag = rng.choice(("--nosuch", "--json=maybe", "-", "--", "--out", "\x1b[31m", "--case", "99"))
            argv.append(flag)
            sub = "garbage_flag"
        use_subprocess = hostile_file in ("fifo", "/dev/zero")
        case = Case("cli", f"{cmd}:{sub}", i, "forcecontrol " + " ".join(a if len(a) < 40 else a[:20] + "..." for a in argv),
                    prepare=_prepare(hostile_file, fname), invalid=invalid)
        if use_subprocess:
            case.argv = argv
        else:
            case.action = lambda d, argv=argv: invoke(argv)
        out.append(case)
    return out
