"""A controller object in your own fixed-rate 1 kHz loop, as on a real arm.

The loop reads the joint state and the wrist wrench from an interface you supply, steps the
controller, writes the torques, and measures the compute time of every cycle (read, control
law, safety checks). Replace ``StandInArm`` by your robot's driver: it only needs the three
methods of ``ArmInterface``. The stand-in integrates the chapter's arm against a stiff plane and
reads its force through a realistic sensor (noise, quantisation, 1-sample delay, 100 Hz
filter, zeroing) so that the script runs anywhere.

The controller is the impact-safe set-up of the ``impact`` scenario: approach under impedance
control, force control (inner velocity loop, critically damped on k_e = 10⁴ N/m) once in
contact, all inside the safety layer (torque, torque-rate, force and speed limits).

Run: ``python examples/own_loop.py`` (2 s of real time).
"""

from __future__ import annotations

import time
from typing import Protocol

import numpy as np

import forcecontrol as fc
from forcecontrol.safety import Safety
from forcecontrol.sensors import RealisticForceSensor
from forcecontrol.transitions import ContactSupervisor

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


def wait_until(deadline: float) -> None:
    """Sleep most of the way, spin the last 0.3 ms (time.sleep alone overshoots by ~0.1 ms)."""
    while (left := deadline - time.perf_counter()) > 3e-4:
        time.sleep(left - 3e-4)
    while time.perf_counter() < deadline:
        pass


def run(robot: ArmInterface, controller: fc.Controller, reference, cycles: int) -> dict[str, np.ndarray]:
    """The fixed-rate loop. Returns per-cycle times [s] and overrun flags.

    ``compute``: read state and wrench, reference, control step (what the cycle must fit);
    ``control``: reference and control step only; ``lateness``: wake-up time after the tick.

    A cycle that ends after the next tick is an overrun: that tick is dropped and the schedule
    restarts from now (a real-time loop never tries to catch up with a burst of cycles).
    """
    q, qd = robot.read_state()
    m0 = fc.Measurement(q, qd, robot.read_wrench())
    controller.reset(m0, reference.at(0.0))
    controller.step(0.0, m0, reference.at(0.0))  # warm-up (compiles on first use), motors still off
    controller.reset(m0, reference.at(0.0))
    compute, control, late = np.empty(cycles), np.empty(cycles), np.empty(cycles)
    overrun = np.zeros(cycles, dtype=bool)
    tick = time.perf_counter()
    for k in range(cycles):
        wait_until(tick)
        t0 = time.perf_counter()
        q, qd = robot.read_state()
        h = robot.read_wrench()
        tr = time.perf_counter()
        u = controller.step(k * PERIOD, fc.Measurement(q, qd, h), reference.at(k * PERIOD))
        t1 = time.perf_counter()
        robot.write_torque(u)
        compute[k], control[k], late[k] = t1 - t0, t1 - tr, t0 - tick
        tick += PERIOD
        if time.perf_counter() > tick:
            overrun[k], tick = True, time.perf_counter()
    return {"compute": compute, "control": control, "lateness": late, "overrun": overrun}


def main(cycles: int = 2000) -> dict[str, np.ndarray]:
    q0 = fc.CHAPTER_ARM.inverse_kinematics([0.95, 0.0])
    robot = StandInArm(q0, samples=cycles + 1)
    controller = make_controller()
    reference = fc.LinearPath([0.95, 0.0], [1.05, 0.0], 0.6, accel_time=0.1, force=[10.0, 0.0])
    stats = run(robot, controller, reference, cycles)
    c = 1e6 * stats["compute"]
    print(f"final f_x = {robot.plane.wrench(robot.arm.forward_kinematics(robot.q), np.zeros(2))[0]:.2f} N (f_d = 10 N); "
          "events:", *(f"\n  t = {e['t']:.3f} s: {e['event']}: {e['detail']}" for e in controller.events))
    ctl = 1e6 * stats["control"]
    print(f"control step (reference + controller) per cycle: median {np.median(ctl):.0f} µs, "
          f"p99 {np.percentile(ctl, 99):.0f} µs")
    print(f"compute per cycle: median {np.median(c):.0f} µs, p99 {np.percentile(c, 99):.0f} µs, max {c.max():.0f} µs; "
          f"wake-up lateness p99 {1e6 * np.percentile(stats['lateness'], 99):.0f} µs; "
          f"overruns: {int(stats['overrun'].sum())} of {len(c)}")
    return stats


if __name__ == "__main__":
    main()
