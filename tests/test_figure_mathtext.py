"""[figure] mathtext = true: a user's own $...$ in titles, notes and case labels is drawn as mathtext (issue 28)."""

from __future__ import annotations

import pytest

from forcecontrol.errors import ScenarioError
from forcecontrol.scenarios import load_scenario, scenario_source

pytest.importorskip("matplotlib")

TITLE = r"impedance, $k_e$ and $\alpha^2$"


def _scenario(tmp_path, lines: str, label: str | None = None):
    text = scenario_source("example-9.2").read_text(encoding="utf-8")
    text = text.replace('title = "Fig. 9.4: impedance control, environments of different compliance"',
                        f"title = '{TITLE}'\n{lines}", 1)
    if label is not None:
        text = text.replace('label = "k_x = 1e4 N/m"', f"label = '{label}'", 1)
    path = tmp_path / "m.toml"
    path.write_text(text, encoding="utf-8")
    return load_scenario(path)


def _texts(run, fig_index: int = 0):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig = run.plot()
    try:
        fig.canvas.draw()  # mathtext is parsed here
        return [t.get_text() for t in fig.findobj(matplotlib.text.Text)]
    finally:
        plt.close(fig)


def test_mathtext_true_draws_the_users_dollars_and_false_escapes_them(tmp_path):
    """With mathtext = true the title and a case label keep their $...$ (drawn as math); by default they are escaped."""
    label = r"$k_x = 10^4$ N/m"
    on = _scenario(tmp_path, "mathtext = true", label).with_(duration=0.05).run()
    texts = _texts(on)
    assert TITLE in texts and label in texts
    off = _scenario(tmp_path, "", label).with_(duration=0.05).run()
    texts = _texts(off)
    assert TITLE.replace("$", r"\$") in texts and label.replace("$", r"\$") in texts


def test_mathtext_key_is_declared_and_a_bad_expression_is_refused_on_load(tmp_path):
    """The schema declares [figure] mathtext (bool, default false); '$\\frac{$' with mathtext = true is a ScenarioError
    on load naming the figure, the text and the remedy; a non-bool value is refused too."""
    from forcecontrol.scenarios.model import FIGURE_FIELDS

    assert FIGURE_FIELDS["mathtext"].kind == "bool" and FIGURE_FIELDS["mathtext"].default is False
    want = (r"\[figure\]: mathtext = true, but the case label '\$\\\\frac\{\$' is not valid mathtext \(.*ParseSyntaxException"
            r".*write a literal dollar as \\\$, or set mathtext = false")
    with pytest.raises(ScenarioError, match=want):
        _scenario(tmp_path, "mathtext = true", r"$\frac{$")
    with pytest.raises(ScenarioError, match="mathtext"):
        _scenario(tmp_path, 'mathtext = "yes"')
    assert _scenario(tmp_path, "", r"$\frac{$").figures[0]["mathtext"] is False  # literal text: nothing to parse
