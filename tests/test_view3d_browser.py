"""The 3-D view in a real browser: headless Chromium (the system's package, Selenium) opens the page over
file:// with the network switched off, WebGL draws it, the slider scrubs it. Skipped without Chromium
unless FORCECONTROL_REQUIRE_BROWSER is set (tests/test_workbench_browser.py's rule). Screenshots
(1280×800) go to the folder named by FORCECONTROL_SCREENSHOTS (docs/img/view3d/ holds the committed ones)."""

from __future__ import annotations

import base64
import io
import json
import os
import time
from pathlib import Path

import numpy as np
import pytest

import forcecontrol as fc
from test_workbench_browser import CHROMEDRIVER, CHROMIUM, _errors, pytestmark  # noqa: F401 - the skip mark

pytest.importorskip("meshcat")
pytest.importorskip("pinocchio")

_READY = """
const done = arguments[arguments.length - 1];
const t0 = performance.now();
(function poll() {
  const canvas = document.querySelector('#meshcat-pane canvas');
  const gl = window.fcViewer && fcViewer.renderer && fcViewer.renderer.getContext();
  if (window.fcReady === true && canvas && gl && !gl.isContextLost()) { done(true); return; }
  if (performance.now() - t0 > 60000) { done(false); return; }
  setTimeout(poll, 50);
})();
"""

_SCRUB = """
const slider = document.getElementById('fc-time');
slider.value = arguments[0];
slider.dispatchEvent(new Event('input'));
return [window.fcFrame, document.getElementById('fc-readout').textContent, fcViewer.capture_image()];
"""


@pytest.fixture(scope="module")
def offline_driver(tmp_path_factory):
    """Chromium with a 1280×800 viewport and the network emulated offline (DevTools)."""
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    opts = webdriver.ChromeOptions()
    opts.binary_location = str(CHROMIUM)
    for arg in ("--headless", "--no-sandbox", "--disable-gpu", "--no-first-run", "--disable-background-networking",
                "--disable-component-update", "--disable-sync", "--enable-unsafe-swiftshader",
                f"--user-data-dir={tmp_path_factory.mktemp('chromium-profile')}", "--window-size=1280,800"):
        opts.add_argument(arg)
    # the performance log records every request the page makes (Network.requestWillBeSent), blocked or not
    opts.set_capability("goog:loggingPrefs", {"browser": "ALL", "performance": "ALL"})
    d = webdriver.Chrome(service=Service(str(CHROMEDRIVER)), options=opts)
    d.set_page_load_timeout(120)
    d.set_script_timeout(90)
    d.execute_cdp_cmd("Emulation.setDeviceMetricsOverride", {"width": 1280, "height": 800, "deviceScaleFactor": 1,
                                                             "mobile": False})
    d.execute_cdp_cmd("Network.enable", {})
    d.execute_cdp_cmd("Network.emulateNetworkConditions", {"offline": True, "latency": 0, "downloadThroughput": -1,
                                                           "uploadThroughput": -1})
    # Chromium 150 no longer carries that emulated offline state into a file:// page (navigator.onLine stays true
    # there, measured): block every network scheme as well, which holds on any version
    d.execute_cdp_cmd("Network.setBlockedURLs", {"urls": [f"{s}://*" for s in ("http", "https", "ws", "wss")]})
    yield d
    d.quit()


def _pixels(data_url: str) -> np.ndarray:
    from PIL import Image

    return np.asarray(Image.open(io.BytesIO(base64.b64decode(data_url.split(",", 1)[1]))).convert("RGB"), dtype=int)


def _open_and_scrub(driver, page: Path, name: str, tmp_path: Path) -> None:
    """Open ``page`` offline, wait for WebGL, scrub to the first and the last frame: the pixels differ, the
    read-out follows; save a 1280×800 screenshot at the last frame."""
    driver.get_log("performance")  # drop what earlier pages requested
    driver.get(page.resolve().as_uri())
    assert driver.execute_async_script(_READY), "the WebGL view did not come up"
    last = int(driver.execute_script("return document.getElementById('fc-time').max"))
    assert last > 5
    frame0, text0, img0 = driver.execute_script(_SCRUB, 0)
    frame1, text1, img1 = driver.execute_script(_SCRUB, last)
    assert (frame0, frame1) == (0, last) and text0.startswith("t = 0.000 s") and text0 != text1
    a, b = _pixels(img0), _pixels(img1)
    assert a.shape == b.shape and a.std() > 5  # something is drawn (not a blank canvas)
    changed = np.any(np.abs(a - b) > 16, axis=2).mean()
    assert changed > 0.001, f"scrubbing changed {changed:.4%} of the pixels"
    entries = driver.execute_script("return performance.getEntriesByType('resource').map(e => e.name)")
    assert not [e for e in entries if e.startswith(("http:", "https:"))], entries
    asked = [json.loads(e["message"])["message"] for e in driver.get_log("performance")]
    urls = [m["params"]["request"]["url"] for m in asked if m["method"] == "Network.requestWillBeSent"]
    assert urls and all(u.startswith(("file:", "data:", "blob:")) for u in urls), urls  # nothing asked of the network
    assert _errors(driver) == [], _errors(driver)
    time.sleep(0.3)
    shot = Path(os.environ.get("FORCECONTROL_SCREENSHOTS") or tmp_path) / f"{name}.png"
    shot.parent.mkdir(parents=True, exist_ok=True)
    driver.save_screenshot(str(shot))
    from PIL import Image

    assert Image.open(shot).size == (1280, 800)


def test_panda_view_offline_scrubbed(offline_driver, tmp_path):
    """The Panda pressing the table: meshes, table, arrow drawn by WebGL from file:// with no network; the
    slider moves the robot and the arrow (the pixels of the first and last frames differ)."""
    run = fc.scenario("panda-admittance-contact").run()
    page = run.view3d(tmp_path / "panda.html")
    _open_and_scrub(offline_driver, page, "panda-admittance-contact", tmp_path)


def test_planar_arm_view_offline_scrubbed_and_played(offline_driver, tmp_path):
    """The chapter's arm (Example 9.2) in the same viewer, scrubbed; the play button advances the frames."""
    run = fc.scenario("example-9.2").run()
    page = run.view3d(tmp_path / "planar.html")
    _open_and_scrub(offline_driver, page, "example-9.2-planar-arm", tmp_path)
    offline_driver.execute_script(_SCRUB, 0)
    offline_driver.find_element("id", "fc-play").click()
    time.sleep(1.0)
    assert offline_driver.execute_script("return window.fcFrame") > 0
