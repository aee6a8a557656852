"""The fuzz campaign's cases, their classifier and its table (issue 28 item 8).

A :class:`Case` is one generated input: it writes its files into its own folder (``prepare``),
then either calls the library in this process (``action``) or runs the ``forcecontrol``
command in a subprocess (``argv``). :func:`classify` runs it and returns one outcome of
:data:`OUTCOMES`:

``success``        the call returned (or the command exited 0) and the oracle had nothing to say;
``clean_error``    a :class:`~forcecontrol.errors.ForceControlError` (or a CLI exit 1/2 with no traceback);
``raw_traceback``  any other exception, or traceback text on the command's stderr;
``hang``           the case ran past its time limit (``signal.alarm`` in process, a subprocess timeout);
``silent``         a success where the input cannot mean what it says (``Case.invalid``: the mutation made a
                   value non-finite, out of its documented range, of the wrong type or shape, an unknown key...)
                   with no warning and no note; or text from a file reached the terminal with its escape bytes;
``outside_write``  a file appeared or changed in the campaign's sentinel tree (outside the case's folder).
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import re
import signal
import subprocess
import sys
import traceback
import warnings
from collections import Counter, defaultdict
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from forcecontrol.errors import ForceControlError

OUTCOMES = ("success", "clean_error", "raw_traceback", "hang", "silent", "outside_write")
BAD = ("raw_traceback", "hang", "silent", "outside_write")
KINDS = ("scenario", "data", "urdf", "cli", "api")

INPROCESS_LIMIT = 60  # [s] per in-process case: a hang detector (a first compile of a new law can take 20 s)
SUBPROCESS_LIMIT = 60  # [s] per CLI subprocess (start-up 2-4 s; a first compile after a source change 30 s and more)


@dataclass
class Case:
    """One generated input."""

    kind: str  # one of KINDS
    sub: str  # the mutation (or call) kind
    index: int
    describe: str  # what was mutated, for the failure list
    prepare: Callable[[Path], None] | None = None  # writes the input files into the case folder
    action: Callable[[Path], Any] | None = None  # in process: called in the case folder; returns notes (list[str]) or None
    argv: list[str] | None = None  # or: the forcecontrol command line, run in the case folder
    invalid: bool = False  # the oracle: success needs a warning or a note
    check_escapes: bool = False  # text with escape bytes went in: none may come out on the terminal
    limit: float = INPROCESS_LIMIT

    @property
    def name(self) -> str:
        return f"{self.kind}-{self.index:05d}-{self.sub}"


@dataclass
class Outcome:
    """What a case did."""

    case: Case
    outcome: str
    detail: str = ""
    extra: dict[str, Any] = field(default_factory=dict)


@dataclass
class CliEnd:
    """How a command run in process (typer's CliRunner) ended."""

    code: int
    stdout: str
    stderr: str
    exception: BaseException | None = None


def invoke(args: list[str]) -> CliEnd:
    """``forcecontrol ARGS`` in this process (typer's CliRunner; a raw exception is caught and kept)."""
    from typer.testing import CliRunner

    from forcecontrol.cli.app import app

    r = CliRunner().invoke(app, [str(a) for a in args], env={"COLUMNS": "200", "NO_COLOR": "1"})
    return CliEnd(r.exit_code, r.stdout, r.stderr, r.exception)


class Hang(BaseException):
    """A case ran past its time limit (BaseException: a library's ``except Exception`` must not swallow it)."""


def _alarm(signum, frame):
    raise Hang


# ----------------------------------------------------------------------------- the sentinel tree


def make_sandbox(root: Path) -> Path:
    """The campaign's folder: ``sentinel/`` (files no case may touch) and ``cases/``; returns ``sentinel``."""
    sentinel = root / "sentinel"
    (sentinel / "deep" / "er").mkdir(parents=True, exist_ok=True)
    (sentinel / "existing_folder").mkdir(exist_ok=True)
    (sentinel / "notes.csv").write_text("my,notes\n1,2\n")
    (sentinel / "deep" / "er" / "keep.txt").write_text("keep\n")
    (root / "cases").mkdir(exist_ok=True)
    return sentinel


def snapshot(root: Path) -> dict[str, tuple[int, int]]:
    """Every file and folder of the sandbox outside ``cases/`` (the sentinel tree, the root's entries)."""
    out: dict[str, tuple[int, int]] = {}
    for dirpath, dirnames, filenames in os.walk(root):
        if Path(dirpath) == root and "cases" in dirnames:
            dirnames.remove("cases")
        for n in filenames + dirnames:
            p = os.path.join(dirpath, n)
            with contextlib.suppress(OSError):
                st = os.lstat(p)
                out[p] = (st.st_size, st.st_mtime_ns)
    return out


def case_folder(root: Path, case: Case) -> Path:
    d = root / "cases" / case.kind / f"{case.index:05d}"
    d.mkdir(parents=True, exist_ok=True)
    return d


# ----------------------------------------------------------------------------- the classifier


NOTE_WORDS = ("warning", "note", "refused", "ignored", "sanitised", "sanitized", "renamed", "instead")


def _noted(text: str) -> bool:
    low = text.lower()
    return any(w in low for w in NOTE_WORDS)


#: a note the harness causes, not the mutation: every scenario is shortened to a 0.05-s run, shorter than its
#: settle_window (0.1 s by default), and the library says so (SettleWindowNote); it answers no mutation but that key's
_HARNESS_NOTE = re.compile(r"^.*settle_window \S+ s is longer than the run.*$", re.M)


def _own_notes(case: Case, text: str) -> str:
    """``text`` without the harness's notes (kept when the mutation is about settle_window itself)."""
    return text if "settle_window" in case.describe else _HARNESS_NOTE.sub("", text)


def _json_noted(case: Case, stdout: str) -> bool:
    """A non-empty ``notes`` or ``warnings`` list anywhere in a JSON output (not the key alone: ``run --json`` has a
    ``warnings`` list in every case, empty when nothing was said); not JSON: either key in the text."""
    try:
        doc = json.loads(stdout)
    except ValueError:
        return '"notes"' in stdout or '"warnings"' in stdout
    found: list[Any] = []

    def walk(x: Any) -> None:
        if isinstance(x, dict):
            for k, v in x.items():
                if k in ("notes", "warnings") and isinstance(v, list):
                    found.extend(e for e in v if _own_notes(case, json.dumps(e)).strip())
                elif k in ("notes", "warnings") and v:
                    found.append(v)
                walk(v)
        elif isinstance(x, list):
            for v in x:
                walk(v)

    walk(doc)
    return bool(found)


def _library_warnings(caught: list[warnings.WarningMessage]) -> list[str]:
    """Warnings a user would see from the library (not NumPy's floating-point RuntimeWarnings, not deprecations)."""
    out = []
    for w in caught:
        if issubclass(w.category, (DeprecationWarning, PendingDeprecationWarning, ResourceWarning, ImportWarning)):
            continue
        if w.category is RuntimeWarning and "forcecontrol" not in str(w.filename):
            continue
        out.append(f"{w.category.__name__}: {w.message}")
    return out


def _run_inprocess(case: Case, d: Path) -> Outcome:
    old_cwd = os.getcwd()
    previous = signal.signal(signal.SIGALRM, _alarm)
    stdout, stderr = io.StringIO(), io.StringIO()
    try:
        os.chdir(d)
        with warnings.catch_warnings(record=True) as caught, contextlib.redirect_stdout(stdout), \
                contextlib.redirect_stderr(stderr):
            warnings.simplefilter("always")
            signal.alarm(max(1, int(case.limit)))
            try:
                notes = case.action(d)
            finally:
                signal.alarm(0)
    except Hang:
        return Outcome(case, "hang", f"no answer within {case.limit:.0f} s")
    except ForceControlError as exc:
        return Outcome(case, "clean_error", f"{type(exc).__name__}: {str(exc)[:300]}")
    except BaseException as exc:  # noqa: BLE001 - the very thing under test
        tb = traceback.format_exception(type(exc), exc, exc.__traceback__)
        where = next((ln.strip() for ln in reversed(tb) if "/forcecontrol/" in ln and "File" in ln), "")
        return Outcome(case, "raw_traceback", f"{type(exc).__name__}: {str(exc)[:300]} [{where}]")
    finally:
        signal.signal(signal.SIGALRM, previous)
        os.chdir(old_cwd)
    if isinstance(notes, CliEnd):
        return _cli_result(case, notes.code, notes.stdout, notes.stderr, notes.exception)
    notes = [str(n) for n in notes] if isinstance(notes, (list, tuple)) else []
    text = stdout.getvalue() + stderr.getvalue()
    heard = [h for h in _library_warnings(caught) + [n for n in notes if n] if _own_notes(case, h).strip()]
    text = _own_notes(case, text)
    if case.check_escapes and "\x1b" in text:
        return Outcome(case, "silent", "an escape sequence from the input reached the terminal")
    if case.invalid and not heard and not _noted(text):
        return Outcome(case, "silent", "accepted with no warning and no note")
    return Outcome(case, "success", "; ".join(heard)[:300])


def _cli_result(case: Case, code: int, stdout: str, stderr: str = "", exception: BaseException | None = None) -> Outcome:
    """Classify a command's end: exit code, its output, the exception a CliRunner caught."""
    if exception is not None and not isinstance(exception, SystemExit):
        if isinstance(exception, Hang):
            return Outcome(case, "hang", f"no answer within {case.limit:.0f} s")
        tb = traceback.format_exception(type(exception), exception, exception.__traceback__)
        where = next((ln.strip() for ln in reversed(tb) if "/forcecontrol/" in ln and "File" in ln), "")
        return Outcome(case, "raw_traceback", f"{type(exception).__name__}: {str(exception)[:300]} [{where}]")
    if "Traceback (most recent call last)" in stderr or "Traceback (most recent call last)" in stdout:
        last = [ln for ln in stderr.strip().splitlines() if ln.strip()][-1:] or [""]
        return Outcome(case, "raw_traceback", f"exit {code}, traceback on stderr: {last[0][:300]}")
    if code in (1, 2):
        return Outcome(case, "clean_error", f"exit {code}: {' '.join(stderr.split())[:300]}")
    if code != 0:
        return Outcome(case, "raw_traceback", f"exit {code} (neither 0, 1 nor 2): {' '.join(stderr.split())[:300]}")
    if case.check_escapes and "\x1b" in stdout + stderr:
        return Outcome(case, "silent", "an escape sequence from the input reached the terminal")
    if case.invalid and not _noted(_own_notes(case, stderr)) and not _json_noted(case, stdout):
        return Outcome(case, "silent", "exit 0 with no warning on stderr and no note in the output")
    return Outcome(case, "success", " ".join(stderr.split())[:200])


def _run_subprocess(case: Case, d: Path) -> Outcome:
    env = {**os.environ, "COLUMNS": "200", "NO_COLOR": "1", "PYTHONIOENCODING": "utf-8"}
    try:
        r = subprocess.run([sys.executable, "-m", "forcecontrol", *case.argv], cwd=d, capture_output=True,
                           timeout=case.limit, env=env, stdin=subprocess.DEVNULL)
    except subprocess.TimeoutExpired:
        return Outcome(case, "hang", f"no exit within {case.limit:.0f} s")
    return _cli_result(case, r.returncode, r.stdout.decode("utf-8", "replace"), r.stderr.decode("utf-8", "replace"))


def classify(case: Case, root: Path) -> Outcome:
    """Prepare and run one case in its folder under ``root/cases``; the outcome, sentinel tree checked."""
    d = case_folder(root, case)
    before = snapshot(root)
    try:
        if case.prepare is not None:
            case.prepare(d)
    except BaseException as exc:  # noqa: BLE001 - a generator bug must show, not stop the campaign
        return Outcome(case, "raw_traceback", f"(generator) {type(exc).__name__}: {exc}")
    if case.argv is not None:
        case.limit = min(case.limit, SUBPROCESS_LIMIT)
        out = _run_subprocess(case, d)
    else:
        out = _run_inprocess(case, d)
    after = snapshot(root)
    changed = sorted(p for p in after if before.get(p) != after[p])
    if changed:
        return Outcome(case, "outside_write", f"wrote {changed[:3]}", {"was": out.outcome})
    return out


# ----------------------------------------------------------------------------- the table


def tabulate(outcomes: list[Outcome]) -> dict[str, Counter]:
    rows: dict[str, Counter] = defaultdict(Counter)
    for o in outcomes:
        rows[o.case.kind]["tried"] += 1
        rows[o.case.kind][o.outcome] += 1
    return rows


def format_table(outcomes: list[Outcome], by: str = "kind") -> str:
    """Counts as a Markdown table: one row per kind (or per ``kind/sub`` with ``by="sub"``), and a total."""
    rows: dict[str, Counter] = defaultdict(Counter)
    for o in outcomes:
        key = o.case.kind if by == "kind" else f"{o.case.kind}/{o.case.sub}"
        rows[key]["tried"] += 1
        rows[key][o.outcome] += 1
    cols = ("tried", *OUTCOMES)
    lines = ["| input | " + " | ".join(cols) + " |", "|---" * (len(cols) + 1) + "|"]
    total: Counter = Counter()
    order = sorted(rows, key=lambda k: (KINDS.index(k.split("/")[0]) if k.split("/")[0] in KINDS else 99, k))
    for k in order:
        total.update(rows[k])
        lines.append(f"| {k} | " + " | ".join(str(rows[k][c]) for c in cols) + " |")
    lines.append("| **total** | " + " | ".join(str(total[c]) for c in cols) + " |")
    return "\n".join(lines)


def failures(outcomes: list[Outcome]) -> list[Outcome]:
    return [o for o in outcomes if o.outcome in BAD]
