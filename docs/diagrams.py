"""The chapter's figures for the documentation, drawn with matplotlib when the site is built.

Block diagrams are drawn as a chain of blocks and summing junctions from left to right; signals
fed back or added are drawn as arrows entering a junction from below or above, labelled with the
signal (the full loops of the book's figures, without the crossing wires).
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.patches import Circle, FancyBboxPatch  # noqa: E402

BOX_W, BOX_H, SUM_R, GAP = 1.7, 0.8, 0.18, 0.75


def chain(path: Path, title: str, items: list[dict], caption: str = "") -> Path:
    """Draw a left-to-right block diagram.

    Each item is ``{"kind": "in"|"box"|"sum"|"out", "text": str, "out": label of the arrow leaving it,
    "side": [(sign, label, "below"|"above"), ...] (junctions only), "w": width (boxes)}``.
    """
    x = 0.0
    pos = []
    for it in items:
        w = {"in": 0.9, "out": 0.9, "sum": 2 * SUM_R}.get(it["kind"], it.get("w", BOX_W))
        pos.append((x, w))
        x += w + GAP
    width = x - GAP
    fig, ax = plt.subplots(figsize=(max(6.0, 0.95 * width), 2.7))
    ax.set_xlim(-0.2, width + 0.2)
    ax.set_ylim(-1.5, 1.5)
    ax.axis("off")
    for it, (x0, w) in zip(items, pos):
        k = it["kind"]
        if k == "box":
            ax.add_patch(FancyBboxPatch((x0, -BOX_H / 2), w, BOX_H, boxstyle="round,pad=0.02", fc="#EAF2FB", ec="k", lw=1))
            ax.text(x0 + w / 2, 0, it["text"], ha="center", va="center", fontsize=9)
        elif k == "sum":
            ax.add_patch(Circle((x0 + SUM_R, 0), SUM_R, fc="w", ec="k", lw=1))
            for sign, label, where in it.get("side", []):
                y = -1.05 if where == "below" else 1.05
                tip = -SUM_R if where == "below" else SUM_R
                ax.annotate("", xy=(x0 + SUM_R, tip), xytext=(x0 + SUM_R, y), arrowprops={"arrowstyle": "-|>", "lw": 1})
                ax.text(x0 + SUM_R, y + (-0.12 if where == "below" else 0.12), label, ha="center",
                        va="top" if where == "below" else "bottom", fontsize=9)
                ax.text(x0 + SUM_R + 0.08, tip + (-0.17 if where == "below" else 0.12), sign, fontsize=9)
        elif k in ("in", "out"):
            ax.text(x0 + w / 2, 0.12, it["text"], ha="center", va="bottom", fontsize=10)
    for i in range(len(items) - 1):
        (x0, w0), (x1, _) = pos[i], pos[i + 1]
        start = x0 + (w0 if items[i]["kind"] != "in" else 0.0)
        ax.annotate("", xy=(x1 + (w0 * 0 if items[i + 1]["kind"] != "out" else pos[i + 1][1]), 0), xytext=(start, 0),
                    arrowprops={"arrowstyle": "-|>", "lw": 1.1})
        label = items[i].get("out")
        if label:
            ax.text((start + x1) / 2, 0.1, label, ha="center", va="bottom", fontsize=9)
        if items[i + 1]["kind"] == "sum" and items[i]["kind"] != "sum":
            ax.text(x1 - 0.12, -0.3, "+", fontsize=9)
    ax.set_title(title, fontsize=10)
    if caption:
        fig.text(0.5, 0.02, caption, ha="center", fontsize=8, color="0.3")
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return path


def _manip(text: str = "manipulator\nand environment") -> dict:
    return {"kind": "box", "text": text, "w": 1.9}


def draw_all(folder: Path) -> list[Path]:
    """Every figure of the chapter pages into ``folder``; returns the files."""
    folder = Path(folder)
    out = []
    out.append(chain(folder / "compliance.png", "Active compliance: PD with gravity compensation (9.15), (8.110)", [
        {"kind": "in", "text": r"$x_d$"},
        {"kind": "sum", "side": [("−", r"$x_e$", "below")], "out": r"$\tilde{x}$"},
        {"kind": "box", "text": r"$K_P$", "w": 0.9},
        {"kind": "sum", "side": [("−", r"$K_D J_{A_d}\dot q$", "below")]},
        {"kind": "box", "text": r"$J_{A_d}^T(q)$", "w": 1.1},
        {"kind": "sum", "side": [("+", r"$g(q)$", "above")], "out": r"$u$"},
        _manip(),
        {"kind": "out", "text": r"$x_e,\ h_e$"},
    ], caption="At equilibrium K_P acts as a spring between the desired and the end-effector frames: h_e = K_P dx_e,d (9.19)."))
    out.append(chain(folder / "impedance.png", "Impedance control with force measurement (9.30), (9.31)", [
        {"kind": "in", "text": r"$x_d, \dot x_d, \ddot x_d$"},
        {"kind": "box", "text": "impedance\ncontrol (9.31)", "out": r"$y$", "w": 1.8},
        {"kind": "box", "text": "inverse\ndynamics (9.30)", "w": 1.8},
        {"kind": "sum", "side": [("+", r"$J^T h_e$", "below")], "out": r"$u$"},
        _manip(),
        {"kind": "out", "text": r"$q, \dot q, h_e$"},
    ], caption="Measured: q, q̇ (for x_e, ẋ_e and the inverse dynamics) and h_e; the loop behaves as "
               "M_d x̃̈ + K_D x̃̇ + K_P x̃ = h_A (9.32)."))
    out.append(chain(folder / "force-inner-position.png", "Force control with inner position loop (9.39)-(9.43)", [
        {"kind": "in", "text": r"$f_d$"},
        {"kind": "sum", "side": [("−", r"$f_e$", "below")]},
        {"kind": "box", "text": r"$C_F = K_F + K_I\int$", "out": r"$x_F$", "w": 1.8},
        {"kind": "sum", "side": [("−", r"$x_e$", "below")]},
        {"kind": "box", "text": r"$K_P$", "w": 0.8},
        {"kind": "sum", "side": [("−", r"$K_D\dot x_e$", "below")]},
        {"kind": "box", "text": "inverse\ndynamics", "w": 1.4},
        _manip(),
        {"kind": "out", "text": r"$f_e, x_e$"},
    ]))
    out.append(chain(folder / "force-inner-velocity.png", "Force control with inner velocity loop (9.45), (9.46)", [
        {"kind": "in", "text": r"$f_d$"},
        {"kind": "sum", "side": [("−", r"$f_e$", "below")]},
        {"kind": "box", "text": r"$K_F$", "out": r"$x_F$", "w": 0.8},
        {"kind": "box", "text": r"$K_P$", "w": 0.8},
        {"kind": "sum", "side": [("−", r"$K_D\dot x_e$", "below")]},
        {"kind": "box", "text": "inverse\ndynamics", "w": 1.4},
        _manip(),
        {"kind": "out", "text": r"$f_e, \dot x_e$"},
    ]))
    out.append(chain(folder / "force-parallel.png", "Parallel force/position control (9.48)", [
        {"kind": "in", "text": r"$f_d$"},
        {"kind": "sum", "side": [("−", r"$f_e$", "below")]},
        {"kind": "box", "text": r"$C_F = K_F + K_I\int$", "out": r"$x_F$", "w": 1.8},
        {"kind": "sum", "side": [("+", r"$x_d$", "above"), ("−", r"$x_e$", "below")]},
        {"kind": "box", "text": r"$K_P$", "w": 0.8},
        {"kind": "sum", "side": [("−", r"$K_D\dot x_e$", "below")]},
        {"kind": "box", "text": "inverse\ndynamics", "w": 1.4},
        _manip(),
        {"kind": "out", "text": r"$f_e, x_e$"},
    ]))
    out.append(chain(folder / "hybrid.png", "Hybrid force/motion control (9.77), (9.91)", [
        {"kind": "in", "text": r"$\lambda_d$"},
        {"kind": "sum", "side": [("−", r"$\lambda = S_f^\dagger h_e$", "below")]},
        {"kind": "box", "text": "force law\n" + r"$f_\lambda$ (9.81), (9.92)-(9.94)", "w": 2.4},
        {"kind": "box", "text": r"$S_f$ or $C'S_f$", "w": 1.3},
        {"kind": "sum", "side": [("+", r"$S_v\alpha_\nu$: motion law (9.80), (9.95) on $\nu_d$", "above")], "out": r"$\alpha$"},
        {"kind": "box", "text": "inverse\ndynamics", "w": 1.4},
        _manip(),
        {"kind": "out", "text": r"$h_e, v_e$"},
    ]))
    out.append(_constraint_sketch(folder / "constraints.png"))
    return out


def _constraint_sketch(path: Path) -> Path:
    """The π/4 plane of Example 9.4: constraint frame, S_f (force) and S_v (velocity) directions."""
    fig, ax = plt.subplots(figsize=(5.2, 4.2))
    a = np.pi / 4
    t = np.array([np.cos(a), np.sin(a)])
    n = np.array([-np.sin(a), np.cos(a)])
    p = np.array([1.0, 0.0])
    line = np.array([p - 0.6 * t, p + 1.2 * t])
    ax.plot(line[:, 0], line[:, 1], color="0.3", lw=2)
    for s in np.linspace(-0.6, 1.2, 40):
        q0 = p + s * t
        q1 = q0 - 0.06 * n + 0.04 * t
        ax.plot([q0[0], q1[0]], [q0[1], q1[1]], color="0.6", lw=0.6)
    c = p + 0.4 * t
    kw = {"arrowstyle": "-|>", "lw": 1.8}
    ax.annotate("", xy=c + 0.35 * t, xytext=c, arrowprops={**kw, "color": "#0072B2"})
    ax.annotate("", xy=c + 0.35 * n, xytext=c, arrowprops={**kw, "color": "#D55E00"})
    ax.text(*(c + 0.38 * t), r"$x_c$: $S_v$ (motion, $\nu$)", color="#0072B2", fontsize=9)
    ax.text(*(c + 0.38 * n + np.array([-0.25, 0.02])), r"$y_c$: $S_f$ (force, $\lambda$)", color="#D55E00", fontsize=9)
    ax.plot(*c, "ko", ms=4)
    ax.text(*(c + np.array([0.04, -0.1])), r"$O_c$", fontsize=9)
    ax.text(1.25, -0.35, "natural: $\\dot o_y^c = 0$, $f_x^c = 0$\nartificial: $f_y^c = \\lambda_d$, $\\dot o_x^c = \\nu_d$",
            fontsize=8.5, bbox={"fc": "w", "ec": "0.7"})
    ax.set_xlim(0.3, 2.2)
    ax.set_ylim(-0.6, 1.3)
    ax.set_aspect("equal")
    ax.set_xlabel("x₀ [m]")
    ax.set_ylabel("y₀ [m]")
    ax.grid(True, lw=0.3)
    ax.set_title("Example 9.4: the π/4 plane, constraint frame and selection", fontsize=10)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return path
