"""The log of one simulated (or replayed) run: :class:`SimulationResult`."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np

from ..core.axes import REFERENCE_FIELDS, joint_columns
from ..core.axes import axis_names as _axis_names
from ..errors import ParameterError

__all__ = ["SimulationResult"]


@dataclass(frozen=True)
class SimulationResult:
    """The log of one run, one row per control sample (base frame, SI units).

    Attributes:
        t: sample times (N+1,) [s].
        q, qd: joint positions and velocities (N+1, n) [rad], [rad/s].
        x, xd: end-effector position and velocity (N+1, m) [m], [m/s].
        wrench: true contact force h_e exerted on the environment (N+1, m) [N].
        wrench_measured: what the controller read (N+1, m) [N].
        torque: joint torques applied from that sample on (N+1, n) [N m].
        reference: packed references (N+1, 6 m), blocks as in ``REFERENCE_FIELDS``.
        label: the case's label.
        metadata: scenario, gains, environment, versions (JSON-serialisable).
        events: what the controller logged (safety reactions, contact transitions), each a dict
            with at least ``t`` [s] and ``event``; empty when the controller logs nothing.
        signals: per-sample signals the controller logged through its ``signals()`` method
            (e.g. ``tank_energy`` of a variable impedance), name -> (N+1,) or (N+1, k) array;
            empty when the controller logs none. Scalar ones are also :meth:`columns`.
        torque_commanded: with an :class:`~forcecontrol.sim.actuators.Actuator`, what the controller
            commanded (N+1, n) [N m] (``torque`` is then what the actuator applied); else None.
    """

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    x: np.ndarray
    xd: np.ndarray
    wrench: np.ndarray
    wrench_measured: np.ndarray
    torque: np.ndarray
    reference: np.ndarray
    label: str = ""
    metadata: dict[str, Any] = field(default_factory=dict)
    events: list[dict[str, Any]] = field(default_factory=list)
    signals: dict[str, np.ndarray] = field(default_factory=dict)
    torque_commanded: np.ndarray | None = None

    def __repr__(self) -> str:
        """A short summary (no arrays): label, samples, duration, dimensions, engine and logged events."""
        n = int(self.t.shape[0])
        span = f"{float(self.t[0]):g}..{float(self.t[-1]):g} s" if n else "empty"
        return (f"SimulationResult({self.label!r}, {n} samples, t = {span}, joints={self.q.shape[1]}, m={self.m}, "
                f"engine={self.metadata.get('engine')!r}, events={len(self.events)}, signals={sorted(self.signals)})")

    @property
    def m(self) -> int:
        """Operational-space dimension."""
        return int(self.x.shape[1])

    def reference_block(self, name: str) -> np.ndarray:
        """One block of the reference log, e.g. ``"position"`` or ``"force"``, (N+1, m)."""
        i = REFERENCE_FIELDS.index(name)
        return self.reference[:, i * self.m : (i + 1) * self.m]

    def final(self) -> dict[str, Any]:
        """The last sample: time, tip position and contact force (plain lists)."""
        return {
            "t": float(self.t[-1]),
            "tip_position": self.x[-1].tolist(),
            "contact_force": self.wrench[-1].tolist(),
        }

    def final_values(self) -> dict[str, float]:
        """The last sample with named components: ``t``, the pose (``x y`` planar; ``x y z rx ry rz``
        in 6-D), the twist (``vx ...``) and the contact wrench (``fx ...``, ``mx my mz`` in 6-D)."""
        return self._named(-1, -1)

    def settled_values(self, window: float = 0.1) -> dict[str, float]:
        """Means over the last ``window`` seconds with named components (as :meth:`final_values`)."""
        sel = self.t >= self.t[-1] - window - 1e-12
        return self._named(sel, None)

    def _named(self, sel: Any, t_index: int | None) -> dict[str, float]:
        pose, twist, wrench = _axis_names(self.m)
        out: dict[str, float] = {} if t_index is None else {"t": float(self.t[t_index])}
        for names, data in ((pose, self.x), (twist, self.xd), (wrench, self.wrench)):
            row = data[sel] if t_index is not None else data[sel].mean(axis=0)
            out.update({n: float(v) for n, v in zip(names, np.atleast_1d(row))})
        return out

    def plot(self, *signals: str, t_max: float | None = None, path: str | Path | None = None) -> Any:
        """A figure of this run, one panel per signal against time (matplotlib).

        Args:
            signals: column names (``"x"``, ``"fx"``, ``"u1"``, ...; see :meth:`columns`) or groups:
                ``"position"``, ``"velocity"``, ``"force"``, ``"torque"``. Default: position and force.
            t_max: time-axis limit [s]; path: save a PNG there (the figure is closed).

        Returns:
            The matplotlib Figure, or the saved path.
        """
        from ..viz.plotting import plot_results

        pose, twist, wrench = _axis_names(self.m)
        groups = {"position": pose, "velocity": twist, "force": wrench,
                  "torque": [f"u{i + 1}" for i in range(self.q.shape[1])]}
        wanted = signals or ("position", "force")
        cols = self.columns()
        names: list[str] = []
        for sig in wanted:
            if sig in groups:
                names.extend(groups[sig])
            elif sig in cols:
                names.append(sig)
            else:
                raise ParameterError(
                    f"unknown signal {sig!r}; expected a group ({', '.join(groups)}) or a column ({', '.join(cols)})"
                )
        return plot_results([self], names, title=self.label, t_max=t_max, path=path)

    def to_pandas(self):  # pragma: no cover - thin pandas wrapper
        """The log as a pandas DataFrame, one column per named signal (see :meth:`columns`)."""
        return self.to_dataframe()

    def settled(self, signal: str = "wrench", window: float = 0.1) -> np.ndarray:
        """Mean of a logged signal over the last ``window`` seconds (an array; see :meth:`settled_values`)."""
        data = getattr(self, signal)
        sel = self.t >= self.t[-1] - window - 1e-12
        return data[sel].mean(axis=0)

    def peak_contact_force_norm(self) -> float:
        """max_k ||h_e(t_k)|| [N]."""
        return float(np.linalg.norm(self.wrench, axis=1).max())

    def columns(self) -> dict[str, np.ndarray]:
        """Flat named columns: ``t``, joints ``q1 qd1 u1 ...``, pose, twist and wrench per axis.

        Axis names: ``x y (z)`` for positions, ``vx vy (vz)`` velocities, ``fx fy (fz)`` forces;
        a 6-D operational space adds ``rx ry rz`` (orientation coordinates), ``wx wy wz``
        (angular velocity) and ``mx my mz`` (moments). References are ``ref_<field>_<axis>``.
        """
        pose, twist, wrench = _axis_names(self.m)
        cols = joint_columns(self.t, self.q, self.qd, self.torque, self.torque_commanded, "uc{}")
        for i in range(self.m):
            cols[pose[i]] = self.x[:, i]
            cols[twist[i]] = self.xd[:, i]
            cols[wrench[i]] = self.wrench[:, i]
            cols[f"{wrench[i]}_measured"] = self.wrench_measured[:, i]
        for name in REFERENCE_FIELDS:
            block = self.reference_block(name)
            for i in range(self.m):
                cols[f"ref_{name}_{pose[i]}"] = block[:, i]
        for name, v in self.signals.items():
            if v.ndim == 1 and v.shape[0] == self.t.shape[0]:
                cols[name] = v
        return cols

    def to_dataframe(self):  # pragma: no cover - thin pandas wrapper
        """The log as a pandas DataFrame (pandas is imported here only)."""
        import pandas as pd

        return pd.DataFrame(self.columns())

    def save(self, path: str | Path, format: Literal["csv", "parquet"] = "csv") -> tuple[Path, Path]:
        """Write the log (CSV or Parquet) and its metadata (JSON beside it).

        Args:
            path: file stem (dots allowed) or a name ending in .csv/.parquet/.json, which is replaced.
            format: ``"csv"`` or ``"parquet"`` (needs pyarrow).

        Returns:
            The data file and the metadata file paths.
        """
        if format not in ("csv", "parquet"):
            raise ParameterError(f"format must be 'csv' or 'parquet'; got {format!r}")
        path = Path(path)
        stem = path.with_suffix("") if path.suffix in (".csv", ".parquet", ".json") else path
        data = stem.parent / f"{stem.name}.{format}"
        meta = stem.parent / f"{stem.name}.json"
        data.parent.mkdir(parents=True, exist_ok=True)
        cols = self.columns()
        if format == "csv":
            header = ",".join(cols)
            np.savetxt(data, np.column_stack(list(cols.values())), delimiter=",", header=header, comments="", fmt="%.10g")
        else:
            import pyarrow as pa
            import pyarrow.parquet as pq

            table = pa.table(cols)
            table = table.replace_schema_metadata({"forcecontrol": json.dumps(self.metadata)})
            pq.write_table(table, data)
        meta.write_text(json.dumps({"label": self.label, **self.metadata}, indent=2))
        return data, meta
