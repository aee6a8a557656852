"""End-to-end journey (issue 27): ``forcecontrol tune`` started as the README says and driven in headless Chromium.

The page loads and plots the run, a slider moved by a key press brings a new plot, **Save tuned scenario** writes
a TOML that ``forcecontrol run`` then runs to the closed form of the tuned stiffness, and Ctrl-C stops the server.
Uses the browser fixtures of tests/test_workbench_browser.py (skipped without Chromium unless
FORCECONTROL_REQUIRE_BROWSER is set, which then fails).
"""

from __future__ import annotations

import json
import os
import re
import select
import signal
import socket
import subprocess
import time
from pathlib import Path

import numpy as np
import pytest

from journeys_helpers import assert_figure, executable, forcecontrol, shell
from test_workbench_browser import _FX, _HANDLES, _LABELS, _WAIT_MODEL, _errors, _shot, driver, pytestmark  # noqa: F401

README_TUNE = "forcecontrol tune mine.toml --port 5006 --no-browser --save tuned/mine.toml"


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("localhost", 0))
        return s.getsockname()[1]


def _save_button(browser):
    return browser.execute_script("""
      const out = [];
      (function walk(root) {
        root.querySelectorAll('button').forEach(b => { if (b.textContent.includes('Save tuned')) out.push(b); });
        root.querySelectorAll('*').forEach(el => { if (el.shadowRoot) walk(el.shadowRoot); }); })(document);
      return out;""")


def test_tune_started_as_the_readme_says_driven_in_chromium_then_run(driver, tmp_path):  # noqa: F811 - the fixture
    """README's `tune mine.toml --port P --no-browser --save tuned/mine.toml`: page plots the run, a key press on the
    stiffness slider re-plots, Save writes a TOML that `run` takes to f = k K_P / (k + K_P) * 0.1; Ctrl-C stops it."""
    from selenium.webdriver.common.keys import Keys

    readme = (Path(__file__).resolve().parents[1] / "README.md").read_text(encoding="utf-8")
    assert README_TUNE in readme
    shell(tmp_path, "forcecontrol show example-9.2 > mine.toml")
    port = _free_port()  # the README's 5006 may be taken on a shared machine: the same line with a free port
    args = README_TUNE.replace("5006", str(port)).split()[1:]
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}  # its banner line through a pipe as on a terminal
    proc = subprocess.Popen([executable(), *args], cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env=env)
    try:
        ready, _, _ = select.select([proc.stdout], [], [], 300)
        assert ready, "tune printed no address within 300 s"
        line = proc.stdout.readline()  # "forcecontrol tune NAME: http://localhost:PORT/  (Save writes ...; Ctrl-C stops)"
        assert f"http://localhost:{port}/" in line and "tuned/mine.toml" in line, line + proc.stderr.read()
        url = re.search(r"http://\S+/", line).group(0)
        deadline = time.time() + 120
        while time.time() < deadline:
            with socket.socket() as s:
                if s.connect_ex(("localhost", port)) == 0:
                    break
            assert proc.poll() is None, proc.stderr.read()
            time.sleep(0.2)
        driver.get(url)
        assert driver.execute_async_script(_WAIT_MODEL), "the page never showed the simulated response"
        time.sleep(0.5)
        _shot(driver, "journey-tune-loaded")
        assert _errors(driver) == []
        before = np.array(driver.execute_script(_FX))
        # the page plots the scenario's first case (k = 1e4 N/m): the book's 200 N at the end
        assert before[-1] == pytest.approx(200.0, rel=5e-3)
        handles, labels = driver.execute_script(_HANDLES), driver.execute_script(_LABELS)
        i = next(j for j, t in enumerate(labels) if t.startswith("k_e [N/m]"))
        handles[i].send_keys(Keys.ARROW_RIGHT)
        t0, after = time.time(), before
        while time.time() - t0 < 20 and np.array_equal(after, before):
            time.sleep(0.05)
            after = np.array(driver.execute_script(_FX))
        assert not np.array_equal(after, before), "moving the slider did not bring a new plot"
        k_new = float(driver.execute_script(_LABELS)[i].rsplit(":", 1)[1])
        assert k_new > 1e4
        buttons = _save_button(driver)
        assert len(buttons) == 1
        buttons[0].click()
        saved = tmp_path / "tuned" / "mine.toml"
        t0 = time.time()
        while not saved.exists() and time.time() - t0 < 20:
            time.sleep(0.05)
        assert saved.exists(), "Save did not write tuned/mine.toml"
        time.sleep(0.3)  # the file is written in one go; let the writer close it
        assert _errors(driver) == []
    finally:
        proc.send_signal(signal.SIGINT)  # Ctrl-C, as the page's banner says
        try:
            _, err = proc.communicate(timeout=30)
        except subprocess.TimeoutExpired:
            proc.kill()
            _, err = proc.communicate()
    assert proc.returncode is not None and "Traceback" not in err, err[-3000:]
    # the saved scenario runs; its force is the series springs' k K_P / (k + K_P) (x_d - x_r) with the tuned k
    doc = json.loads(forcecontrol(tmp_path, "run", "tuned/mine.toml", "--json").stdout)
    case = doc["cases"][0]
    import forcecontrol as fc

    k_saved = fc.scenario(saved).cases[0].config["environment"]["stiffness"]
    assert k_saved == pytest.approx(k_new, rel=1e-3)
    assert case["settled"]["fx"] == pytest.approx(k_saved * 2500 / (k_saved + 2500) * 0.1, rel=5e-3)
    assert np.asarray(after)[-1] == pytest.approx(case["final"]["contact_force"][0], rel=1e-6)  # what the page showed
    assert_figure(tmp_path / doc["files"]["figure"])
