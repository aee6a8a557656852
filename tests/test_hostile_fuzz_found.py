"""Defects the fuzz campaign (``tools/fuzz_report.py``, ``tests/fuzz``) found, each refused now as a library error.

Each test names the campaign input that found it (kind, seed, index) and checks the error type and
that the message names the parameter or file and the problem. Special files are read in a
subprocess with a timeout (a hang detector, not a speed test).
"""

from __future__ import annotations

import math
import os
import subprocess
import sys

import numpy as np
import pytest

import forcecontrol as fc
from forcecontrol.errors import ForceControlError, ParameterError, ScenarioError

HUGE = 10**400  # an integer of 401 digits


_LOAD = """
import sys
from forcecontrol.scenarios import load_scenario
try:
    load_scenario(sys.argv[1])
except Exception as exc:
    print(type(exc).__name__, exc)
"""


@pytest.mark.parametrize("kind", ["fifo", "/dev/zero"])
def test_a_scenario_file_that_is_a_fifo_or_a_device_is_refused_without_blocking(tmp_path, kind):
    """`forcecontrol run pipe.toml` blocked forever and `analyze /dev/zero` read until memory ran out (cli, seed 1)."""
    if kind == "fifo":
        p = tmp_path / "pipe.toml"
        os.mkfifo(p)
    else:
        p = kind
    out = subprocess.run([sys.executable, "-c", _LOAD, str(p)], capture_output=True, text=True, timeout=120).stdout.strip()
    assert out.startswith("ScenarioError"), out
    assert str(p) in out and ("a FIFO" if kind == "fifo" else "a device") in out, out


def test_a_huge_scenario_file_is_refused_by_size(tmp_path, monkeypatch):
    """A scenario file above the size limit is refused before it is read (the limit is lowered here to keep it small)."""
    from forcecontrol.scenarios import core

    p = tmp_path / "big.toml"
    p.write_text('name = "x"\n' + "# padding\n" * 200)
    monkeypatch.setattr(core, "MAX_SCENARIO_BYTES", 100)
    with pytest.raises(ScenarioError, match=r"big.toml.*above the limit of 100 bytes"):
        core.load_scenario(p)


def test_a_folder_named_like_a_table_is_refused_with_bag_keywords(tmp_path):
    """`forcecontrol convert folder.csv` (the CLI passes the bag topics) ended in a raw TypeError (cli, seed 1, case 28)."""
    from forcecontrol.realarm.io import read_recording

    p = tmp_path / "folder.csv"
    p.mkdir()
    with pytest.raises(ParameterError, match=r"folder.csv.*it is a folder"):
        read_recording(p, joint_topic="/joint_states", wrench_topic=None)


@pytest.mark.parametrize("key, value", [("inertia", [HUGE, 1.0]), ("stiffness", HUGE), ("damping", [1.0, HUGE])])
def test_an_integer_beyond_a_float_in_a_gain_is_a_parameter_error(key, value):
    """A 401-digit integer as a gain ended in a raw OverflowError from float() (api, seed 1, cases 21, 65, 101)."""
    kw = {"inertia": 100.0, "damping": 500.0, "stiffness": 2500.0, "force_gain": 0.05, key: value}
    with pytest.raises(ParameterError, match=rf"{key} must be .*401 digits"):
        fc.InnerVelocityForceController(fc.PlanarTwoLink(), **kw)


@pytest.mark.parametrize("kw, match", [({"substeps": math.nan}, "substeps must be a positive integer; got nan"),
                                       ({"substeps": math.inf}, "substeps must be a positive integer; got inf"),
                                       ({"max_log_bytes": math.nan}, "max_log_bytes must be a positive number"),
                                       ({"max_log_bytes": -1}, "max_log_bytes must be a positive number")])
def test_simulate_refuses_non_finite_substeps_and_log_limit(kw, match):
    """substeps=nan ended in 'cannot convert float NaN to integer'; max_log_bytes=nan ran (NaN compares False) (api, seed 1)."""
    arm = fc.PlanarTwoLink()
    plane = fc.ElasticPlane(point=[1.0, 0.0], normal=[-1.0, 0.0], stiffness=1e3)
    ctl = fc.ImpedanceController(arm, inertia=100, damping=500, stiffness=2500)
    with pytest.raises(ParameterError, match=match):
        fc.simulate(arm, plane, ctl, fc.Setpoint([1.1, 0.1]), q0=[math.pi / 3, -2 * math.pi / 3], duration=0.02, **kw)


def test_a_non_finite_contact_mode_is_a_parameter_error():
    """Stiffness 1.7e308: an infinite contact mode, then OverflowError in int(ceil(inf)) (scenario, seed 1, case 8)."""
    from forcecontrol.sim.limits import check_substeps

    with pytest.raises(ParameterError, match="non-finite contact mode"):
        check_substeps(4, 100, 0.001, 1.7e308, "python", rate=math.inf, explicit=True)


@pytest.mark.parametrize("column, value", [("fx", 1e300), ("x", -1e308), ("t", 1e300)])
def test_absurd_reference_samples_are_refused(tmp_path, column, value):
    """A sampled reference with a 1e300 force was accepted silently, and one with -1e308 ended in SciPy's raw ValueError."""
    from forcecontrol.trajectories.sampled import SampledReference

    t = 0.01 * np.arange(6)
    cols = {"t": t, "x": 1 + t, "y": 0 * t, "fx": 10 * t, "fy": 0 * t}
    cols[column] = cols[column].copy()
    cols[column][-1] = value
    p = tmp_path / "ref.csv"
    p.write_text("t,x,y,fx,fy\n" + "".join(",".join(repr(float(cols[c][i])) for c in cols) + "\n" for i in range(6)))
    with pytest.raises(ParameterError, match=r"samples must be at most 1e\+12 in magnitude.*at sample 5"):
        SampledReference.from_file(p)


def test_absurd_link_mass_in_a_urdf_is_refused(tmp_path):
    """A link with mass="1e300" loaded silently (every torque then overflows) (urdf, seed 1, case 1)."""
    pytest.importorskip("pinocchio")
    from forcecontrol.robots.pinocchio import PinocchioRobot, model_path

    text = model_path("chapter_arm").read_text().replace('<mass value="50"/>', '<mass value="1e300"/>', 1)
    p = tmp_path / "arm.urdf"
    p.write_text(text)
    with pytest.raises(ParameterError, match=r"arm.urdf.*<mass value> must be at most 1e\+09 kg; got 1e\+300"):
        PinocchioRobot.from_urdf(p, "tip", task="planar")


def test_every_refusal_here_is_a_force_control_error():
    """The types used above are the library's (a check of this file's premise)."""
    assert issubclass(ParameterError, ForceControlError) and issubclass(ScenarioError, ForceControlError)
