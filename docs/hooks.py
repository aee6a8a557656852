"""MkDocs hooks: what the site shows is computed when it is built.

* ``on_files``: the gallery (every built-in scenario run, its figures drawn, its checks against
  the book tabled) and the chapter's figures (block diagrams drawn with matplotlib, an animation of
  the arm on the plane) are generated into a temporary folder and added to the site.
* ``on_page_markdown``: every ``python`` code block of a chapter or getting-started page is run
  (the blocks of a page share one namespace, in order); its printed output is shown under it. An
  exception fails the build, so an example that stops working cannot stay in the docs.
* ``on_env``: the Sphinx-style cross-references of the docstrings (``:class:`X```), made markers by
  the griffe extension of ``sphinx_roles.py``, become links (see that module).

The hooks import the package from ``src/`` next to this folder when it is not installed.
"""

from __future__ import annotations

import atexit
import contextlib
import io
import os
import re
import shutil
import sys
import tempfile
import textwrap
import time
import traceback
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

from mkdocs.exceptions import PluginError  # noqa: E402
from mkdocs.structure.files import File  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT / "src") not in sys.path:
    sys.path.insert(0, str(ROOT / "src"))
sys.path.insert(0, str(Path(__file__).resolve().parent))

import diagrams  # noqa: E402
import sphinx_roles  # noqa: E402

_GENERATED: dict[str, Path] = {}  # src_uri -> file, made once per process (mkdocs serve rebuilds)
_TIMES: dict[str, float] = {}
EXEC_PAGES = re.compile(r"^(chapter/|guides/|getting-started\.md$|conventions\.md$)")


def _outdir() -> Path:
    d = os.environ.get("FORCECONTROL_DOCS_CACHE")
    if d:
        path = Path(d)
        path.mkdir(parents=True, exist_ok=True)
        return path
    path = Path(tempfile.mkdtemp(prefix="forcecontrol-docs-"))
    atexit.register(shutil.rmtree, path, ignore_errors=True)  # kept while `mkdocs serve` rebuilds, gone after
    return path


def _generate() -> dict[str, Path]:
    if _GENERATED:
        return _GENERATED
    out = _outdir()
    t0 = time.perf_counter()
    for uri in diagrams.draw_all(out / "chapter" / "img"):
        _GENERATED[f"chapter/img/{uri.name}"] = uri
    _GENERATED["chapter/img/interaction.gif"] = _interaction(out / "chapter" / "img" / "interaction.gif")
    _TIMES["diagrams"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    for rel, path in _gallery(out / "gallery").items():
        _GENERATED[f"gallery/{rel}"] = path
    _TIMES["gallery"] = time.perf_counter() - t0
    return _GENERATED


def _interaction(path: Path) -> Path:
    """Example 9.2's arm pushing on the stiff plane under impedance control, animated."""
    import forcecontrol as fc
    from forcecontrol.viz.animation import animate_run

    arm = fc.PlanarTwoLink()
    q0 = arm.inverse_kinematics([1.0, 0.0], elbow="up")
    plane = fc.ElasticPlane(point=[1.0, 0.0], normal=[-1.0, 0.0], stiffness=1e4)
    ctl = fc.ImpedanceController(arm, inertia=100, damping=500, stiffness=2500, force_measurement=True)
    res = fc.simulate(arm, plane, ctl, fc.Setpoint([1.1, 0.1]), q0=q0, duration=2.0)
    return animate_run(res, arm, plane, path, max_frames=40, title="Example 9.2, k_x = 1e4 N/m")


def on_config(config):
    """List every built-in scenario's gallery page under "Gallery" in the navigation."""
    from forcecontrol.scenarios import list_scenarios

    pages = ["gallery/index.md"] + [{name: f"gallery/{name}.md"} for name in list_scenarios()]
    for i, entry in enumerate(config["nav"] or []):
        if isinstance(entry, dict) and "Gallery" in entry:
            config["nav"][i] = {"Gallery": pages}
    return config


def on_files(files, config):
    """Add the generated pages and images to the site."""
    for uri, path in _generate().items():
        existing = files.get_file_from_path(uri)
        if existing is not None:
            files.remove(existing)
        files.append(File.generated(config, uri, abs_src_path=str(path)))
    return files


def on_env(env, config, files):
    """Turn the cross-reference markers of every page into links, before autorefs resolves links."""
    pages = [f.page for f in files if f.page is not None]
    sphinx_roles.resolve_markers(pages, config.plugins["autorefs"])
    return env


def on_post_build(config):
    """Say how long the generated parts took (shown by ``mkdocs build``)."""
    import logging

    logging.getLogger("mkdocs").info(
        "forcecontrol docs: diagrams %.1f s, gallery %.1f s, examples %.1f s",
        _TIMES.get("diagrams", 0.0), _TIMES.get("gallery", 0.0), _TIMES.get("examples", 0.0),
    )


# ---------------------------------------------------------------------------------------------- examples
_BLOCK = re.compile(r"^```python[^\n]*\n(.*?)^```[ \t]*$", re.S | re.M)


def on_page_markdown(markdown, page, config, files):
    """Run the page's python blocks; insert their output; fail the build on an exception."""
    if not EXEC_PAGES.match(page.file.src_uri):
        return markdown
    namespace: dict[str, object] = {"__name__": "__docs__"}
    t0 = time.perf_counter()
    cwd = os.getcwd()
    work = Path(tempfile.mkdtemp(prefix="forcecontrol-example-"))  # removed once the page's blocks have run

    def run(match: re.Match) -> str:
        code = match.group(1)
        buf = io.StringIO()
        os.chdir(work)  # examples that write files write them here, not into the repository
        try:
            with contextlib.redirect_stdout(buf):
                exec(compile(code, f"{page.file.src_uri} (example)", "exec"), namespace)  # noqa: S102
        except Exception as exc:  # the build fails, with the example's traceback
            raise PluginError(
                f"example in {page.file.src_uri} failed:\n{textwrap.indent(code, '    ')}\n{traceback.format_exc()}"
            ) from exc
        finally:
            os.chdir(cwd)
            import matplotlib.pyplot as plt

            plt.close("all")
        printed = buf.getvalue().rstrip()
        block = match.group(0)
        if printed:
            block += "\n\n??? success \"Output (computed when this page was built)\"\n\n" + textwrap.indent(
                "```text\n" + printed + "\n```", "    "
            )
        return block

    try:
        markdown = _BLOCK.sub(run, markdown)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    _TIMES["examples"] = _TIMES.get("examples", 0.0) + time.perf_counter() - t0
    return markdown


# ---------------------------------------------------------------------------------------------- gallery
ANIMATED = ("example-9.2", "panda-table-line")


def _gallery(folder: Path) -> dict[str, Path]:
    """Run every built-in scenario; write its figures, an animation for a few, and one page each."""
    from forcecontrol.scenarios import build_case, list_scenarios, load_scenario, run_scenario
    from forcecontrol.viz.animation import animate_run
    from forcecontrol.viz.plotting import plot_run_figures

    img = folder / "img"
    img.mkdir(parents=True, exist_ok=True)
    made: dict[str, Path] = {}
    index = [
        "# Gallery",
        "",
        "Every built-in scenario (`forcecontrol list`), simulated and drawn **when this site was built**, "
        "with the same code as `forcecontrol run NAME`. Each page shows the scenario's description, its "
        "figures, the settled values and the checks against the book's printed numbers (or the closed form).",
        "",
        "| scenario | title | cases | checks |",
        "|---|---|---|---|",
    ]
    for name, title in list_scenarios().items():
        t0 = time.perf_counter()
        scn = load_scenario(name)
        run = run_scenario(scn)
        figs = plot_run_figures(run, img, name)
        for f in figs:
            made[f"img/{f.name}"] = f
        anims = []
        if name in ANIMATED:
            spec, case = scn.cases[0], run.cases[0]
            parts = build_case(spec, where=name)
            gif = animate_run(case.result, parts["robot"], parts["environment"], img / f"{name}.gif",
                              max_frames=50, title=f"{name}: {case.label}")
            made[f"img/{gif.name}"] = gif
            anims.append(gif)
        elapsed = time.perf_counter() - t0
        checks = [ch for c in run.cases for ch in c.checks]
        ok = sum(ch["ok"] for ch in checks)
        index.append(f"| [{name}]({name}.md) | {_cell(title)} | {len(run.cases)} | {ok}/{len(checks)} met |")
        page = folder / f"{name}.md"
        page.write_text(_scenario_page(scn, run, figs, anims, elapsed), encoding="utf-8")
        made[f"{name}.md"] = page
    index += ["", "Run any of them yourself: `forcecontrol run NAME` (add `--animate` for a GIF of the arm)."]
    (folder / "index.md").write_text("\n".join(index) + "\n", encoding="utf-8")
    made["index.md"] = folder / "index.md"
    return made


def _scenario_page(scn, run, figs, anims, elapsed: float) -> str:
    from forcecontrol.scenarios import scenario_source

    lines = [f"# {scn.name}", "", f"**{scn.title}**", ""]
    if scn.description:
        lines += [" ".join(scn.description.split()), ""]
    lines += ["```bash", f"forcecontrol run {scn.name}", "```", ""]
    for f, fig in zip(figs, scn.figures or ({},)):
        caption = fig.get("title") or scn.title
        lines += [f"![{caption}](img/{f.name})", ""]
        if fig.get("note"):
            lines += ['!!! note "Reading this figure"', "", "    " + " ".join(fig["note"].split()), ""]
    for a in anims:
        lines += [f"![Animation of the first case: the arm, the environment and the contact force](img/{a.name})", ""]
    lines += ["## Settled values", "", "| case | x [m] | y [m] | f_x [N] | f_y [N] | peak \\|f\\| [N] | engine |",
              "|---|---|---|---|---|---|---|"]
    for c in run.cases:
        x, y, fx, fy = (c.metrics.get(k, float("nan")) for k in ("x", "y", "fx", "fy"))
        lines.append(
            f"| {_cell(c.label)} | {x:.5f} | {y:.5f} | {fx:.3f} | {fy:.3f} "
            f"| {c.result.peak_contact_force_norm():.3f} | {c.result.metadata.get('engine')} |"
        )
    checks = [(c.label, ch) for c in run.cases for ch in c.checks]
    if checks:
        lines += ["", "## Against the book (or the closed form)", "",
                  "| case | quantity | simulated | expected | tolerance | rel. error | |", "|---|---|---|---|---|---|---|"]
        for label, ch in checks:
            rel = f"{100 * ch['relative_error']:+.3f} %" if ch["expected"] else "—"  # none of a quantity expected to be 0
            lines.append(
                f"| {_cell(label)} | `{ch['metric']}` | {ch['value']:.6g} | {ch['expected']:.6g} | ±{ch['tolerance']:.3g} "
                f"| {rel} | {'ok' if ch['ok'] else '**MISSED**'} |"
            )
    source = scenario_source(scn.name).read_text(encoding="utf-8")
    lines += ["", f"Simulated in {elapsed:.1f} s while the site was built.", "",
              '??? note "Scenario file (`forcecontrol show ' + scn.name + '`)"', "",
              textwrap.indent("```toml\n" + source.rstrip() + "\n```", "    "), ""]
    return "\n".join(lines)


def _cell(text: str) -> str:
    """Text safe in a markdown table cell."""
    return str(text).replace("|", "\\|").replace("\n", " ")
