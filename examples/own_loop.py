"""A controller object in your own fixed-rate 1 kHz loop, as on a real arm, with its timing measured.

The loop reads the joint state and the wrist wrench from an interface you supply, steps the
controller, writes the torques, and keeps its rate with :class:`forcecontrol.realarm.realtime.RateLimiter`
(sleep until each deadline on ``time.perf_counter``, spin the last 0.3 ms; a cycle that runs into
the next tick is an overrun and the missed ticks are dropped, never run in a burst). At the end
it reports the jitter (wake-up lateness: median, p99, max), the compute time per cycle and the
overruns. Replace the stand-in arms by your robot's driver: it only needs the three methods of
``ArmInterface``.

Two arms, both simulated in real time inside the loop (their integration counts in the cycle's
work; on a real arm ``write_torque`` is a bus write):

* the chapter's arm against a stiff plane, read through a realistic sensor (noise, quantisation,
  1-sample delay, 100 Hz filter, zeroing), controlled by the impact-safe set-up of the ``impact``
  scenario: impedance approach, force control (inner velocity loop, critically damped on
  k_e = 10⁴ N/m) once in contact, all inside the safety layer;
* the Panda (needs Pinocchio) pressing 20 N on a table while tracing a line: the
  ``panda-table-line`` scenario's 6-D hybrid force/motion controller.

When the loop misses deadlines (overruns > 0, or lateness p99 a sizeable part of the period):
see :mod:`forcecontrol.realarm.realtime` for the full list. In short: find out whether the compute or
the wake-up is late (the report separates them); keep logging, plotting and allocation out of
the loop and warm up compiled code before the motors are on; lower the rate (500 Hz suffices
for force loops of tens of Hz bandwidth; retune for the new sample time); run the loop with a
real-time priority (:func:`forcecontrol.realarm.realtime.realtime_priority`, used below: SCHED_FIFO and
memory locked when the user may have them; the report says what was granted), on a PREEMPT_RT
kernel; keep full garbage collections out of the loop (:func:`forcecontrol.realarm.realtime.frozen_heap`,
used below);
or leave the 1 kHz loop to the robot's own real-time controller (libfranka, UR RTDE,
ros2_control) and send it set-points from Python at a lower rate. Never let an overrun go
unnoticed: stop the arm after a few consecutive ones.

Run: ``python examples/own_loop.py [--seconds 2] [--no-realtime]`` (both arms, 2 s of real time each;
``--no-realtime`` keeps the ordinary scheduling, to compare).
"""

from __future__ import annotations

import argparse
import time
from typing import Protocol

import numpy as np

import forcecontrol as fc
from forcecontrol.realarm.realtime import LoopStatistics, RateLimiter, frozen_heap, realtime_priority
from forcecontrol.sensors import RealisticForceSensor
from forcecontrol.supervision.safety import Safety
from forcecontrol.supervision.transitions import ContactSupervisor

PERIOD = 1e-3  # 1 kHz


class ArmInterface(Protocol):
    """What the loop needs from a robot: your driver implements these three calls."""

    def read_state(self) -> tuple[np.ndarray, np.ndarray]:
        """Joint positions [rad] and velocities [rad/s] (n,)."""

    def read_wrench(self) -> np.ndarray:
        """Wrist force in the base frame, gravity-compensated and zeroed (m,) [N]."""

    def write_torque(self, u: np.ndarray) -> None:
        """Joint torques (n,) [N m], held until the next write."""


class StandInArm:
    """The chapter's arm against the plane x = 1 (k_e = 1e4 N/m), integrated over each period."""

    def __init__(self, q0, samples: int = 100_000, substeps: int = 4) -> None:
        self.arm, self.plane = fc.CHAPTER_ARM, fc.ElasticPlane([1.0, 0.0], [-1.0, 0.0], 1e4)
        self.q, self.qd, self.k, self.n = np.array(q0, float), np.zeros(2), 0, substeps
        self.sensor = RealisticForceSensor(noise_std=0.5, bias=[1.0, -0.5], cutoff=100.0, resolution=0.02,
                                           delay_samples=1, zeroing_samples=100, seed=0)
        self.sensor.start(samples, 2, PERIOD, np.zeros(2), self.q)  # noise drawn for `samples` reads
        self.plane.acceleration(self.arm, self.q, self.qd, np.zeros(2))  # warm-up: compiled code loads now, not in cycle 1

    def read_state(self):
        return self.q.copy(), self.qd.copy()

    def read_wrench(self):
        h = self.plane.wrench(self.arm.forward_kinematics(self.q), self.arm.jacobian(self.q) @ self.qd)
        return self.sensor.measure(self.k, self.k * PERIOD, h, self.q)

    def write_torque(self, u):
        dt = PERIOD / self.n
        for _ in range(self.n):  # semi-implicit Euler is enough for a stand-in
            qdd = self.plane.acceleration(self.arm, self.q, self.qd, u)[0]
            self.qd = self.qd + dt * qdd
            self.q = self.q + dt * self.qd
        self.k += 1


def make_controller() -> fc.Controller:
    """Impedance approach, critically damped inner velocity loop in contact, inside the safety layer."""
    arm = fc.CHAPTER_ARM
    motion = fc.ImpedanceController(arm, 100, 2000, 10000)
    force = fc.InnerVelocityForceController(arm, 100, 5000, 2500, [0.0024, 0.0])
    q = arm.inverse_kinematics([1.0, 0.0])
    for c in (motion, force):  # warm-up before the motors are on: compiled code loads on first use
        c.step(0.0, fc.Measurement(q, np.zeros(2), np.zeros(2)), fc.Reference.setpoint([1.0, 0.0], [10.0, 0.0]))
    supervisor = ContactSupervisor(motion, force, [1.0, 0.0], contact_force=2.0, release_force=0.5)
    return Safety(supervisor, max_torque=3000.0, max_torque_rate=2e5, max_force=80.0, max_speed=0.5)


class SimulatedArm:
    """Any robot model against any elastic environment, integrated over each period (exact wrench)."""

    def __init__(self, robot, environment, q0, substeps: int = 4) -> None:
        self.arm, self.env = robot, environment
        self.q, self.qd, self.n = np.array(q0, float), np.zeros(robot.nq), substeps
        self.env.acceleration(robot, self.q, self.qd, np.zeros(robot.nq))  # warm-up before the loop

    def read_state(self):
        return self.q.copy(), self.qd.copy()

    def read_wrench(self):
        return self.env.sampled_wrench(self.arm, self.q, self.qd, np.zeros(self.arm.nq))

    def write_torque(self, u):
        dt = PERIOD / self.n
        for _ in range(self.n):  # semi-implicit Euler is enough for a stand-in
            qdd = self.env.acceleration(self.arm, self.q, self.qd, u)[0]
            self.qd = self.qd + dt * qdd
            self.q = self.q + dt * self.qd


def run(robot: ArmInterface, controller: fc.Controller, reference, cycles: int) -> dict[str, object]:
    """The fixed-rate loop, paced by a RateLimiter. Returns per-cycle times [s], overrun flags and statistics.

    ``compute``: read state and wrench, reference, control step (what the cycle must fit on a
    real arm); ``control``: reference and control step only; ``lateness``: wake-up time after
    the deadline; ``statistics``: :class:`~forcecontrol.realarm.realtime.LoopStatistics` of the whole
    cycle's work (including the stand-in's plant integration in ``write_torque``).

    A cycle whose work ends after the next deadline is an overrun: the ticks it ran over are
    dropped and the schedule keeps its phase (a real-time loop never catches up with a burst).
    """
    q, qd = robot.read_state()
    m0 = fc.Measurement(q, qd, robot.read_wrench())
    controller.reset(m0, reference.at(0.0))
    controller.step(0.0, m0, reference.at(0.0))  # warm-up (compiles on first use), motors still off
    controller.reset(m0, reference.at(0.0))
    compute, control, late = np.empty(cycles), np.empty(cycles), np.empty(cycles)
    overrun = np.zeros(cycles, dtype=bool)
    limiter = RateLimiter(PERIOD, cycles=cycles)
    with frozen_heap():  # no full garbage collection (milliseconds) inside the loop
        for k in range(cycles):
            late[k] = limiter.wait()
            t0 = time.perf_counter()
            t = k * PERIOD  # the stand-ins advance one period per cycle; on a real arm use the schedule's time
            q, qd = robot.read_state()
            h = robot.read_wrench()
            tr = time.perf_counter()
            u = controller.step(t, fc.Measurement(q, qd, h), reference.at(t))
            t1 = time.perf_counter()
            robot.write_torque(u)
            compute[k], control[k] = t1 - t0, t1 - tr
            overrun[k] = limiter.done()
    return {"compute": compute, "control": control, "lateness": late, "overrun": overrun,
            "statistics": limiter.statistics()}


def report(name: str, stats: dict[str, object]) -> LoopStatistics:
    """Print the loop's timing: jitter, compute, overruns."""
    st = stats["statistics"]
    c, ctl = 1e6 * stats["compute"], 1e6 * stats["control"]
    print(f"{name}: {st.summary()}")
    print(f"  control step (reference + controller): median {np.median(ctl):.0f} µs, p99 {np.percentile(ctl, 99):.0f} µs; "
          f"read + control: median {np.median(c):.0f} µs, p99 {np.percentile(c, 99):.0f} µs")
    return st


def chapter_arm(cycles: int) -> dict[str, object]:
    """The chapter's arm: impedance approach, force control in contact, safety layer; realistic sensor."""
    q0 = fc.CHAPTER_ARM.inverse_kinematics([0.95, 0.0])
    robot = StandInArm(q0, samples=cycles + 1)
    controller = make_controller()
    reference = fc.LinearPath([0.95, 0.0], [1.05, 0.0], 0.6, accel_time=0.1, force=[10.0, 0.0])
    stats = run(robot, controller, reference, cycles)
    f = robot.plane.wrench(robot.arm.forward_kinematics(robot.q), np.zeros(2))[0]
    print(f"chapter arm: final f_x = {f:.2f} N (f_d = 10 N); events:",
          *(f"\n  t = {e['t']:.3f} s: {e['event']}: {e['detail']}" for e in controller.events))
    return stats


def panda(cycles: int) -> dict[str, object] | None:
    """The Panda on a table (scenario panda-table-line): 6-D hybrid force/motion control. None without Pinocchio."""
    try:
        import pinocchio  # noqa: F401
    except ImportError:
        print("panda: skipped (needs Pinocchio: pip install 'forcecontrol[pinocchio]')")
        return None
    from forcecontrol.scenarios import build_case, load_scenario

    parts = build_case(load_scenario("panda-table-line").cases[0])
    robot = SimulatedArm(parts["robot"], parts["environment"], parts["q0"], substeps=2)
    stats = run(robot, parts["controller"], parts["reference"], cycles)
    print(f"panda: final f_z = {robot.read_wrench()[2]:.2f} N (f_d = −20 N)")
    return stats


def main(seconds: float = 2.0, realtime: bool = True) -> dict[str, LoopStatistics]:
    import contextlib
    import os

    cycles = int(round(seconds / PERIOD))
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"machine: {os.cpu_count()} cores, load average {load:.2f} (a loaded machine shows long tails and overruns)")
    with realtime_priority(80) if realtime else contextlib.nullcontext() as rt:
        print(f"scheduling: {rt.summary() if rt else 'ordinary (--no-realtime)'}")
        out = {"chapter arm": report("chapter arm", chapter_arm(cycles))}
        stats = panda(cycles)
    if stats is not None:
        out["panda"] = report("panda", stats)
    for name, st in out.items():
        if st.overruns:
            print(f"{name}: {st.overruns} overrun(s): see this file's docstring "
                  "(and forcecontrol.realarm.realtime) for what to do")
    return out


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=2.0, help="real time per arm [s]")
    ap.add_argument("--no-realtime", dest="realtime", action="store_false",
                    help="keep the ordinary scheduling (no SCHED_FIFO, no memory lock)")
    args = ap.parse_args()
    main(args.seconds, args.realtime)
