"""The MuJoCo engine's loop against a plain Python ``mj_step`` loop with the same controller.

Both loops run the Panda on the table of ``panda-table-line`` (6-D hybrid control, 1 ms, the
scenario's substeps) with MuJoCo as the plant. The baseline is the least a user would write:
read q, q̇ and the end-effector contact force (``mj_contactForce`` summed over the contacts),
call ``controller.step``, set ``qfrc_applied``, ``mj_step``. The engine adds logging, the
pose/twist log, the contact-stiffness rescheduling and the divergence checks. Target (issue 14):
engine / baseline <= 1.2.

Run: ``python benchmarks/bench_mujoco.py`` (prints the table; asserts nothing).
"""

from __future__ import annotations

import statistics
import time

import numpy as np


def main(duration: float = 0.5, repeats: int = 5) -> None:
    import mujoco

    from forcecontrol.controllers.base import REFERENCE_FIELDS, Measurement, Reference
    from forcecontrol.engines.mujoco import MujocoPlant
    from forcecontrol.scenarios import build_case, load_scenario

    scn = load_scenario("panda-table-line")
    parts = build_case(scn.cases[0])
    ctl, ref_sig, q0 = parts["controller"], parts["reference"], parts["q0"]
    plant = MujocoPlant(parts["robot"], parts["environment"], sample_time=ctl.sample_time)
    Ts = ctl.sample_time
    N = int(round(duration / Ts))

    def engine() -> None:
        plant.run(ctl, ref_sig, q0=q0, duration=duration)

    def plain() -> None:
        m, d = plant.model, plant.data
        mujoco.mj_resetData(m, d)
        d.qpos[:] = q0
        mujoco.mj_forward(m, d)
        refs = ref_sig.sample(np.arange(N + 1) * Ts)
        mdim = refs.shape[1] // len(REFERENCE_FIELDS)
        buf = np.zeros(6)
        ctl.reset(Measurement(d.qpos.copy(), d.qvel.copy(), np.zeros(mdim)), ref_sig.at(0.0))
        for k in range(N + 1):
            f = np.zeros(3)
            for i in range(d.ncon):
                mujoco.mj_contactForce(m, d, i, buf)
                con = d.contact[i]
                fi = con.frame.reshape(3, 3).T @ buf[:3]
                f += fi if con.geom2 == plant.ee_geom else -fi
            h = np.zeros(mdim)
            h[:3] = -f
            row = refs[k]
            ref = Reference(*(row[i * mdim : (i + 1) * mdim] for i in range(len(REFERENCE_FIELDS))))
            u = ctl.step(k * Ts, Measurement(d.qpos.copy(), d.qvel.copy(), h), ref)
            d.qfrc_applied[:] = u
            for _ in range(plant.substeps):
                mujoco.mj_step(m, d)

    engine()
    plain()
    te, tp = [], []
    for _ in range(repeats):
        for fn, out in ((engine, te), (plain, tp)):
            t0 = time.perf_counter()
            fn()
            out.append(time.perf_counter() - t0)
    e, p = statistics.median(te) / (N + 1) * 1e6, statistics.median(tp) / (N + 1) * 1e6
    print(f"MuJoCo engine loop : {e:8.1f} us per 1 ms sample")
    print(f"plain mj_step loop : {p:8.1f} us per 1 ms sample")
    print(f"ratio engine/plain : {e / p:8.2f}   (target <= 1.2)")


if __name__ == "__main__":
    main()
