"""Text from files (titles, labels, names, messages) reaches a terminal or a figure literally (issue 28, item 6)."""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path

import forcecontrol as fc
from forcecontrol.core.text import LABEL_LIMIT, TITLE_LIMIT, figure_safe, plain_text, shorten, terminal_safe

ESC = "\x1b"


def test_terminal_safe_strips_ansi_csi_sequences_and_keeps_the_text():
    """Colour and cursor sequences (CSI) go; the visible characters, newlines and tabs stay."""
    s = f"{ESC}[1;31mred{ESC}[0m and{ESC}[2J{ESC}[H\tbold\n{ESC}[?25lnext"
    assert terminal_safe(s) == "red and\tbold\nnext"


def test_terminal_safe_strips_osc_8_hyperlinks_and_window_titles():
    """OSC 8 hyperlinks (ST or BEL terminated) keep only their visible text; an OSC window title vanishes whole."""
    link = f"{ESC}]8;;https://evil.example/{ESC}\\click{ESC}]8;;{ESC}\\"
    title = f"{ESC}]0;pwned\x07"
    bel_link = f"{ESC}]8;;file:///etc/passwd\x07here{ESC}]8;;\x07"
    assert terminal_safe(f"a {link} b {title}c {bel_link}") == "a click b c here"


def test_terminal_safe_strips_c1_controls_carriage_returns_and_bidi_overrides():
    """8-bit CSI/OSC, bare C0/C1 controls, CR (which overwrites a line) and U+202E reorderings are removed."""
    s = "ok\x9b31mred\x9d0;t\x9c \x85\x07\x08\rX\u202eevil\u2066"
    assert terminal_safe(s) == "okred Xevil"
    assert ESC not in terminal_safe(f"{ESC}") and terminal_safe(f"half{ESC}[31") == "half"


def test_shorten_and_plain_text_bound_the_length_with_an_ellipsis():
    """Cut texts end in '…' at exactly the limit; short texts are unchanged; plain_text is one line."""
    assert shorten("abc", 3) == "abc" and shorten("abcd", 3) == "ab…"
    assert len(plain_text("x" * 10**6)) == LABEL_LIMIT and plain_text("a\nb\tc") == "a b c"


def test_figure_safe_escapes_mathtext_unless_asked():
    """'$' becomes '\\$' (matplotlib draws a dollar sign), so '$\\frac{$' is text; mathtext=True keeps it."""
    assert figure_safe(r"$\frac{$") == r"\$\frac{\$"
    assert figure_safe("$x^2$", mathtext=True) == "$x^2$"


def _run_result(label: str):
    r = fc.scenario("example-9.2").with_(duration=0.05).run().cases[0].result
    return dataclasses.replace(r, label=label)


def test_a_mathtext_breaking_title_and_label_draw_as_text():
    """A figure titled and labelled '$\\frac{$' draws (no ParseSyntaxException) and shows those characters."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from forcecontrol.viz.plotting import plot_results

    fig = plot_results([_run_result(r"case $\frac{$")], ["fx"], title=r"title $\frac{$")
    try:
        fig.canvas.draw()  # raised matplotlib's ParseSyntaxException before
        texts = [t.get_text() for t in fig.findobj(matplotlib.text.Text)]
        assert r"title \$\frac{\$" in texts and r"case \$\frac{\$" in texts
    finally:
        plt.close(fig)


def test_a_one_megabyte_label_is_drawn_truncated():
    """A 1 MB case label and title reach the figure cut to LABEL_LIMIT / TITLE_LIMIT characters, ending in '…'."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from forcecontrol.viz.plotting import plot_results

    fig = plot_results([_run_result("L" * 10**6)], ["fx"], title="T" * 10**6)
    try:
        fig.canvas.draw()
        texts = [t.get_text() for t in fig.findobj(matplotlib.text.Text)]
        label = next(t for t in texts if t.startswith("LLL"))
        title = next(t for t in texts if t.startswith("TTT"))
        assert len(label) == LABEL_LIMIT and label.endswith("…")
        assert len(title) == TITLE_LIMIT and title.endswith("…")
    finally:
        plt.close(fig)


def test_cli_prints_no_escape_sequence_from_a_scenario_title_or_label(tmp_path):
    """'forcecontrol run' on a file whose title and case label hold ESC sequences prints no ESC byte."""
    from typer.testing import CliRunner

    from forcecontrol.cli import app

    src = Path(fc.__file__).parent / "scenarios" / "example-9.2.toml"
    text = src.read_text(encoding="utf-8")
    title = r'title = "\u001b]0;pwned\u0007\u001b[31mRed title\u001b[0m"'
    text = re.sub(r'^title = ".*"$', lambda m: title, text, count=1, flags=re.M)
    text = re.sub(r'^label = "(.*)"$', lambda m: rf'label = "\u001b]8;;https://evil.example/\u001b\\{m[1]}\u001b]8;;\u001b\\"',
                  text, count=1, flags=re.M)
    path = tmp_path / "esc.toml"
    path.write_text(text.replace("duration = 4.0", "duration = 0.05"), encoding="utf-8")
    assert "\x1b" in fc.scenario(path).title  # the file really holds the sequences
    res = CliRunner().invoke(app, ["run", str(path), "--out", str(tmp_path / "out"), "--no-figure", "--data", "csv"])
    assert res.exit_code == 0, res.output
    out = res.stdout + (res.stderr if res.stderr_bytes is not None else "")
    assert "Red title" in out and "data:k_x = 1e4 N/m" in out and ESC not in out and "\x07" not in out


def test_html_report_shows_a_tag_laden_case_label_as_text():
    """A case label holding plotly/HTML tags and an ESC sequence reaches the report's legend escaped, without ESC."""
    import numpy as np

    from forcecontrol.workbench.report import run_figure

    label = '<a href="https://evil.example/">click</a><b>x</b>\x1b[31m'
    fig = run_figure([({"t": np.array([0.0, 1.0]), "fx": np.array([0.0, 1.0])}, {"label": label})])
    assert fig.data[0].name == '&lt;a href="https://evil.example/"&gt;click&lt;/a&gt;&lt;b&gt;x&lt;/b&gt;'
