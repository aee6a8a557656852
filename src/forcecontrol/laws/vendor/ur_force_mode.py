"""Universal Robots ``force_mode``: documented semantics, and an *inferred* velocity-admittance law.

Documented (URScript manual, e.g. SW 10.7 "force_mode(task_frame, selection_vector, wrench, type,
limits)"; e-Series Script Directory §14.12–14.14 ``force_mode_set_damping``,
``force_mode_set_gain_scaling``; ur_msgs ``SetForceMode.srv``): on each *compliant* axis of the
task frame (``selection_vector`` 1) the robot "adjusts its position … in order to achieve the
specified force/torque" it applies to the environment, at most at the axis's ``limits`` speed;
``damping`` in [0, 1] (default 0.005): "1 is full damping, so the robot will decelerate quickly
if no force is present. A value of 0 is no damping, here the robot will maintain the speed";
``gain_scaling`` in [0, 2] (default 1): "A value larger than 1 can make force mode unstable".
Non-compliant axes follow the program's pose (their limits are deviations before a protective
stop). Written anew from the documentation (survey of issue 30, §4); UR publishes no equations.

**Inferred, not published by UR**: the compliant axes as a first-order velocity admittance with
a force-error input, one update per 2-ms cycle::

    v ← (1 − β(d)) v + T G s_g (F_d − F),   |v| ≤ limit,   x_cmd ← x_cmd + T v

with β(d) = d (d = 0 keeps the speed, d = 1 stops in one cycle, as the manual's words say) and
G [1/kg] the controller's internal gain: identify both from a recorded step (RTDE
``actual_TCP_force``, ``actual_TCP_speed``) before trusting the numbers. In the chapter's terms
this is (9.37) with K_P = 0: mass ``1/(G s_g)``, damping ``β/(T G s_g)``, a speed limit on ż.
"""

from __future__ import annotations

from numba import njit

from .layout import (
    UR_FORCE_MODE_SELECTION,
    UR_FORCE_MODE_STATE_V,
    ur_force_mode_damping,
    ur_force_mode_gain,
    ur_force_mode_gain_scaling,
    ur_force_mode_limits,
    ur_force_mode_state_offset,
    ur_force_mode_wrench,
)


@njit(cache=True)
def ur_force_mode_step(dt, F, p, s):  # pragma: no cover - compiled
    """One cycle of the inferred force-mode law on the task frame's axes (see the module docstring).

    Args:
        dt: the controller period T [s] (2 ms on e-Series).
        F: (m,) the wrench the robot applies to the environment, in the task frame (h_e) [N, N m].
        p: ``layout.UR_FORCE_MODE``: ``[selection (m; 1 compliant, 0 not), wrench F_d (m), limits (m),
            gain G, gain_scaling s_g, damping d]``.
        s: state (``layout.UR_FORCE_MODE_STATE``), advanced in place: ``[v (m), offset (m)]``: the compliant
            axes' speed and the Cartesian offset of the command from the program's pose (task frame) [m/s, m; rad].
            Non-compliant axes keep zero speed and offset.
    """
    m = F.shape[0]
    G = p[ur_force_mode_gain(m)]
    sg = p[ur_force_mode_gain_scaling(m)]
    beta = p[ur_force_mode_damping(m)]
    o_w, o_l, o_off = ur_force_mode_wrench(m), ur_force_mode_limits(m), ur_force_mode_state_offset(m)
    for i in range(m):
        if p[UR_FORCE_MODE_SELECTION + i] == 0.0:
            s[UR_FORCE_MODE_STATE_V + i] = 0.0
            s[o_off + i] = 0.0
            continue
        v = (1.0 - beta) * s[UR_FORCE_MODE_STATE_V + i] + dt * G * sg * (p[o_w + i] - F[i])
        lim = p[o_l + i]
        if v > lim:
            v = lim
        elif v < -lim:
            v = -lim
        s[UR_FORCE_MODE_STATE_V + i] = v
        s[o_off + i] = s[o_off + i] + dt * v
