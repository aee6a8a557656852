"""Kind (e): Python calls: controllers' constructors and ``step``, ``fc.simulate`` and ``Scenario.with_`` given bad values.

Every call here is given one value that cannot mean what it says (NaN, inf, 401 digits, the wrong
shape or type, a sample time <= 0, time that does not advance, an unknown key), so a success with
no warning is a silent acceptance.
"""

from __future__ import annotations

import math
import random
from pathlib import Path
from typing import Any

import numpy as np

from .core import Case

BAD_SCALARS: tuple[Any, ...] = (math.nan, math.inf, -math.inf, 10**400, "abc", None, [], {}, -1e308, 1.7e308, True)
BAD_VECTORS: tuple[Any, ...] = ([1.0, 2.0, 3.0], [1.0], [[1.0, 2.0]], [math.nan, 1.0], [1.0, math.inf], ["a", "b"],
                                np.zeros((2, 2, 2)), [10**400, 1.0])

CONTROLLERS = {
    "ImpedanceController": {"inertia": 100.0, "damping": 500.0, "stiffness": 2500.0},
    "InnerPositionForceController": {"inertia": 100.0, "damping": 500.0, "stiffness": 2500.0, "force_gain": 0.05},
    "InnerVelocityForceController": {"inertia": 100.0, "damping": 500.0, "stiffness": 2500.0, "force_gain": 0.05},
    "ParallelForcePositionController": {"inertia": 100.0, "damping": 500.0, "stiffness": 2500.0, "force_gain": 0.05},
}
#: the controllers above without integrator state (any finite t is theirs to accept)
STATELESS = ("ImpedanceController", "InnerVelocityForceController")
#: keys of Scenario.with_ on example-9.2, and values each of which is invalid there
WITH_KEYS = ("controller.stiffness", "controller.damping", "duration", "sample_time", "robot.q0", "environment.stiffness",
             "environment.point", "reference.position", "settle_window", "substeps", "sensor.noise_std", "sensor.cutoff")
WITH_BAD_KEYS = ("nosuch", "controller.", "", "controller..stiffness", "controller.stiffness.x", "robot.q0[5]",
                 "case", "controller.stiffnes", "environment.type.x", "\x1b[31m")


def _arm():
    import forcecontrol as fc

    return fc.PlanarTwoLink()


Q0 = np.array([math.pi / 3, -2 * math.pi / 3])


def _constructor(rng: random.Random) -> tuple[str, Any]:
    name = rng.choice(sorted(CONTROLLERS))
    kw = dict(CONTROLLERS[name])
    key = rng.choice([*kw, "sample_time"])
    val = rng.choice(BAD_SCALARS + BAD_VECTORS + ((0.0, -0.001) if key == "sample_time" else (-1.0, -100.0)))
    kw[key] = val

    def call(d: Path):
        import forcecontrol as fc

        getattr(fc, name)(_arm(), **kw)

    return f"{name}({key}={str(val)[:30]})", call


def _step(rng: random.Random) -> tuple[str, Any]:
    name = rng.choice(sorted(CONTROLLERS))
    what = rng.choice(("q_shape", "q_nan", "wrench_nan", "wrench_shape", "t_backwards", "t_repeat", "t_nan", "t_inf",
                       "qd_inf", "ref_nan", "ref_shape"))

    def call(d: Path):
        import forcecontrol as fc

        arm = _arm()
        ctl = getattr(fc, name)(arm, **CONTROLLERS[name])
        x = arm.forward_kinematics(Q0) if hasattr(arm, "forward_kinematics") else np.array([1.0, 0.0])
        x = np.asarray(getattr(x, "position", x), float)[:2]
        ref = fc.Reference.setpoint(x + [0.01, 0.0], force=[10.0, 0.0])
        good = fc.Measurement(Q0, np.zeros(2), np.zeros(2))
        t = 0.0
        for _ in range(3):
            ctl.step(t, good, ref)
            t += 0.001
        q, qd, w, tt = Q0, np.zeros(2), np.zeros(2), t
        if what == "q_shape":
            q = np.zeros(3)
        elif what == "q_nan":
            q = np.array([math.nan, 0.0])
        elif what == "wrench_nan":
            w = np.array([math.nan, 0.0])
        elif what == "wrench_shape":
            w = np.zeros(5)
        elif what == "qd_inf":
            qd = np.array([math.inf, 0.0])
        elif what == "t_backwards":
            tt = t - 0.5
        elif what == "t_repeat":
            tt = t - 0.001
        elif what == "t_nan":
            tt = math.nan
        elif what == "t_inf":
            tt = math.inf
        if what == "ref_nan":
            ref = fc.Reference.setpoint([math.nan, 0.0])
        elif what == "ref_shape":
            ref = fc.Reference.setpoint([1.0, 0.0, 0.0, 0.0])
        u = ctl.step(tt, fc.Measurement(q, qd, w), ref)
        if not np.all(np.isfinite(u)):
            raise AssertionError(f"step returned a non-finite torque {u}")
        if what in ("t_backwards", "t_repeat") and not ctl.state.size:
            # documented (Controller.step): a controller without integrator state accepts any finite t
            return ["documented: a stateless controller accepts any finite t"]
        return None

    return f"{name}.step({what})", call


def _simulate(rng: random.Random) -> tuple[str, Any]:
    key, val = rng.choice((
        ("duration", rng.choice((math.nan, -1.0, 0.0, math.inf, 1e300, 10**400, "1"))),
        ("q0", rng.choice(BAD_VECTORS + (None,))),
        ("qd0", rng.choice(BAD_VECTORS)),
        ("substeps", rng.choice((0, -1, 1.5, 10**9, math.nan, 10**400))),
        ("engine", rng.choice(("foo", "", None, 1))),
        ("max_joint_speed", rng.choice((math.nan, -1.0, 0.0))),
        ("max_log_bytes", rng.choice((-1, 0, math.nan))),
        ("sensor", rng.choice(("x", 1, object()))),
        ("label", "\x1b]0;x\x07" + "a" * 10),
    ))

    def call(d: Path):
        import forcecontrol as fc

        arm = _arm()
        plane = fc.ElasticPlane(point=[1.0, 0.0], normal=[-1.0, 0.0], stiffness=1e3)
        ctl = fc.ImpedanceController(arm, inertia=100, damping=500, stiffness=2500, force_measurement=True)
        kw = {"q0": Q0, "duration": 0.02, key: val}
        fc.simulate(arm, plane, ctl, fc.Setpoint([1.1, 0.1]), **kw)

    return f"simulate({key}={str(val)[:30]})", call


def _with(rng: random.Random) -> tuple[str, Any]:
    if rng.random() < 0.3:
        key, val = rng.choice(WITH_BAD_KEYS), 1.0
    else:
        key = rng.choice(WITH_KEYS)
        val = rng.choice(BAD_SCALARS + BAD_VECTORS + (-1.0,) if key not in ("robot.q0", "environment.point",
                                                                             "reference.position") else BAD_VECTORS)

    def call(d: Path):
        import forcecontrol as fc

        scn = fc.scenario("example-9.2")
        if key.startswith("sensor."):
            scn = scn.with_({"sensor": {}})
        scn.with_({key: val})

    return f"scenario('example-9.2').with_({{{key!r}: {str(val)[:30]}}})", call


SUBS = {"constructor": _constructor, "step": _step, "simulate": _simulate, "with_": _with}


def make_cases(seed: int, count: int, sentinel: Path) -> list[Case]:
    rng = random.Random(f"api-{seed}")
    out = []
    for i in range(count):
        sub = rng.choice(sorted(SUBS))
        what, call = SUBS[sub](rng)
        invalid = not what.startswith("simulate(label") and not (sub == "with_" and what.endswith(": None})"))
        if sub == "step" and what.split(".")[0] in STATELESS and ("t_backwards" in what or "t_repeat" in what):
            invalid = False  # a stateless controller accepts any finite t (Controller.step's time rule)
        if sub == "with_" and "-1.0" in what and any(k in what for k in ("robot.q0", "environment.point", "reference.position")):
            invalid = False
        out.append(Case("api", sub, i, what, action=call, invalid=invalid))
    return out
