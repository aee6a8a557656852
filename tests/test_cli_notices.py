"""A command shows the library's warnings as plain ``note:`` / ``warning:`` lines (no library file, line or source)."""

from __future__ import annotations

import io
import json
import warnings
from importlib import resources

from journeys_helpers import forcecontrol


def _short_example_9_2(folder) -> str:
    """Example 9.2 for 0.05 s with a 0.2-s settle window: the library notes that the whole run is averaged."""
    text = (resources.files("forcecontrol.scenarios") / "example-9.2.toml").read_text(encoding="utf-8")
    assert text.count("\nduration = 4.0\n") == 1
    (folder / "short.toml").write_text(text.replace("\nduration = 4.0\n", "\nduration = 0.05\nsettle_window = 0.2\n", 1),
                                       encoding="utf-8")
    return "short.toml"


def test_a_library_note_is_one_plain_line_on_stderr_and_kept_in_json(tmp_path):
    """`run short.toml` (figures on): the settle-window note is a 'note: ' line, without SettleWindowNote, a .py:
    location or the raising source line; `--json` keeps it in the case's warnings."""
    name = _short_example_9_2(tmp_path)
    text = "settle_window 0.2 s is longer than the run (0.05 s): the whole run is averaged"
    table = forcecontrol(tmp_path, "run", name)
    as_json = forcecontrol(tmp_path, "run", name, "--json", "--force")
    for stderr in (table.stderr, as_json.stderr):
        lines = [ln for ln in stderr.splitlines() if "settle_window" in ln]
        assert [ln.split(": ", 1)[0] for ln in lines] == ["note", "note"], stderr  # one line per case
        assert all(ln.startswith(f"note: {name}: [[case]] #") and ln.endswith(f"): {text}") for ln in lines), stderr
        assert "SettleWindowNote" not in stderr and ".py:" not in stderr, stderr
    doc = json.loads(as_json.stdout)
    assert {"kind": "settle-window", "t": None, "text": text} in doc["cases"][0]["warnings"]


def test_only_the_librarys_warnings_are_reformatted_and_the_display_is_put_back():
    """forcecontrol's categories (and a plain UserWarning naming a forcecontrol file) become note:/warning: lines with no
    escape sequence; another package's warning keeps Python's format; the previous display comes back after."""
    import forcecontrol
    from forcecontrol.cli.notices import library_line, show_library_warnings
    from forcecontrol.controllers.search import SearchNote
    from forcecontrol.errors import DriftWarning

    ours = str(forcecontrol.__file__)
    assert library_line("hole found", SearchNote, "/elsewhere/x.py") == "note: hole found\n"
    assert library_line("drifts", DriftWarning, "/elsewhere/x.py") == "warning: drifts\n"
    assert library_line("plain", UserWarning, ours) == "warning: plain\n"  # a bare warnings.warn in the library
    assert library_line("\x1b]0;title\x07red \x1b[31mtext", SearchNote, ours) == "note: red text\n"
    assert library_line("overflow", RuntimeWarning, "/site-packages/numpy/x.py") is None
    assert library_line("overflow encountered in matmul", RuntimeWarning, ours) is None  # NumPy's, keeps its place
    passed_on = []

    def before(message, category, filename, lineno, file=None, line=None):  # the display installed before
        passed_on.append((str(message), category, filename, lineno))

    with warnings.catch_warnings():
        warnings.showwarning = before
        restore = show_library_warnings()
        out = io.StringIO()
        warnings.showwarning("hole found", SearchNote, ours, 12, file=out)
        warnings.showwarning("overflow", RuntimeWarning, "/elsewhere/numpy/x.py", 7, file=out, line="y = x * x")
        assert out.getvalue() == "note: hole found\n"
        assert passed_on == [("overflow", RuntimeWarning, "/elsewhere/numpy/x.py", 7)]
        restore()
        assert warnings.showwarning is before
