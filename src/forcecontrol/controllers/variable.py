"""Variable impedance that stays passive: stiffness and damping schedules with an energy tank.

The chapter's impedance with force measurement, (9.30)–(9.31), closes the loop (9.32)
``M_d x̃̈ + K_D x̃̇ + K_P x̃ = h_A`` (x̃ = x_d − x_e). With constant gains, the storage function

    H = ½ x̃̇ᵀ M_d x̃̇ + ½ x̃ᵀ K_P x̃

obeys ``Ḣ = x̃̇ᵀ h_A − x̃̇ᵀ K_D x̃̇``: the controller only stores or dissipates the energy that
enters through the contact port, so it is passive and stays stable on any passive environment.
Let K_P change in time and ``Ḣ`` gains the term ``½ x̃ᵀ K̇_P x̃``: raising the stiffness while
the spring is stretched *creates* energy, and a stiffness schedule can pump a contact into a
growing oscillation (parametric resonance) however stiff or soft the surface is.

The energy tank (Ferraguti, Secchi, Fantuzzi, "A tank-based approach to impedance control with
variable stiffness", ICRA 2013; the discrete form here is the library's) keeps the books: a
storage T ≥ T_min is filled by a fraction σ of the energy dissipated over each sample (the damper's
``Ts x̃̇ᵀ K_D x̃̇``, capped by what the sampled loop really lost: see :class:`EnergyTank`), and pays for
every stiffness change, ``ΔE = ½ x̃ᵀ (K_new − K_old) x̃``. When the
tank cannot pay (``T − ΔE < T_min``), the change is scaled down to what it can pay; lowering the
stiffness returns energy to the tank (up to T_max, above which energy is dropped, i.e.
dissipated). So with σ ≤ 1

    H + T  ≤  H₀ + T₀ + ∫ x̃̇ᵀ h_A dt,

the controller with its tank is passive, whatever the schedule asks. Damping may vary freely
(any K_D ⪰ 0 only dissipates). M_d is held constant.

How this tank differs from the papers' (Ferraguti et al., ICRA 2013 and IEEE T-RO 31(5) 2015, where the tank
state is x_t with ``T = ½ x_t²``, ``ẋ_t = (σ/x_t) x̃̇ᵀ D x̃̇ − wᵀ x̃̇`` and the variable spring's force
``K_v x̃ = −w x_t`` is supplied through the tank while ``T > ε``), compared by an outside review of the code:

* *What the tank pays for.* The papers keep only the constant part of the stiffness in the storage and pay the
  variable spring's whole power ``x̃̇ᵀ K_v x̃`` from the tank; here the storage H holds the whole K_P and the tank
  pays ``½ x̃ᵀ ΔK x̃`` at each change (the ``½ x̃ᵀ K̇_P x̃`` term). In continuous time the two books differ by
  ``½ x̃ᵀ K_v x̃`` (the papers' tank also holds the variable spring's energy), so the same T₀, T_min and T_max
  are not the same settings in the two schemes.
* *The state.* The energy T itself is kept, not x_t: no ``1/x_t`` at an empty tank, T within
  [T_min, T_max] by construction, and the books exact to round-off at the sample time (the papers' law sampled with
  forward Euler at 1 ms lets T dip below ε and gains energy, the review measured).
* *An empty tank.* The papers' w drops to 0 at ``T ≤ ε``, so the stiffness falls back to its constant part; here
  only the part of a change the tank cannot pay is refused (the stiffness stays where it is) and energy returned by
  lowering it is always taken.
* *σ.* The papers' σ ∈ {0, 1} switches the damper's inflow off above T̄; here ``dissipation_fraction`` σ ∈ [0, 1]
  is a constant share of that inflow, and T_max clips every inflow (energy returned by a lower stiffness too).
* *The damper's inflow* is the energy the damper dissipated over the last sample, capped by what the sampled loop
  really lost (see :class:`EnergyTank`), not the continuous ``σ x̃̇ᵀ K_D x̃̇``.

Each keeps ``H + T`` from growing, so each is passive; they differ in how much stiffness change a given tank
allows.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, ClassVar

import numpy as np

from ..core.validate import as_gain_matrix, gain_scalar, nonnegative_scalar, positive_scalar
from ..errors import DimensionError, ParameterError
from ..laws.layout import IMPEDANCE
from ..robots.base import RobotModel
from .admittance import AdmittanceController
from .base import Measurement, Reference
from .impedance import ImpedanceController

__all__ = [
    "EnergyTank",
    "VariableImpedanceController",
    "VariableAdmittanceController",
    "Schedule",
    "DirectionalStiffness",
    "SinusoidalStiffness",
]

#: a gain schedule: ``schedule(t, x_tilde, x_tilde_dot) -> matrix (m, m)`` (or (m,) diagonal, or a scalar).
Schedule = Callable[[float, np.ndarray, np.ndarray], Any]


class DirectionalStiffness:
    """A state-dependent stiffness: ``high`` while the error shrinks (x̃ᵀ x̃̇ < 0), ``low`` otherwise.

    "Soft when pushed away from the target, firm while returning to it": a plausible rule that
    injects ``½ (high − low) x̃ᵀ x̃`` at every turn of an oscillation and pumps a contact into a
    growing bounce unless an :class:`EnergyTank` pays for the switches (the built-in scenario
    ``variable-stiffness``).

    Args:
        low, high: stiffnesses [N/m], ``0 <= low <= high`` (scalars: ``value · I``).
    """

    def __init__(self, low: float, high: float) -> None:
        self.low = gain_scalar("low", low, "N/m")
        self.high = gain_scalar("high", high, "N/m")
        if self.high < self.low:
            raise ParameterError(f"high must be >= low = {self.low:.6g} N/m; got {high!r}")
        self.__name__ = f"DirectionalStiffness(low={self.low:g}, high={self.high:g})"

    def __call__(self, t: float, x_tilde: np.ndarray, x_tilde_dot: np.ndarray) -> float:
        return self.high if float(x_tilde @ x_tilde_dot) < 0.0 else self.low


class SinusoidalStiffness:
    """A time-varying stiffness ``mean + amplitude · sin(2π frequency t)`` [N/m] (scalar · I).

    Args:
        mean: [N/m]; amplitude: [N/m], ``0 <= amplitude <= mean`` (the stiffness stays >= 0);
        frequency: [Hz], > 0.
    """

    def __init__(self, mean: float, amplitude: float, frequency: float) -> None:
        self.mean = gain_scalar("mean", mean, "N/m")
        self.amplitude = gain_scalar("amplitude", amplitude, "N/m")
        if self.amplitude > self.mean:
            raise ParameterError(f"amplitude must be <= mean = {self.mean:.6g} N/m (stiffness >= 0); got {amplitude!r}")
        self.frequency = positive_scalar("frequency", frequency)
        self.__name__ = f"SinusoidalStiffness(mean={self.mean:g}, amplitude={self.amplitude:g}, frequency={self.frequency:g})"

    def __call__(self, t: float, x_tilde: np.ndarray, x_tilde_dot: np.ndarray) -> float:
        return self.mean + self.amplitude * math.sin(2.0 * math.pi * self.frequency * t)


class EnergyTank:
    """An energy storage that pays for the energy a variable stiffness injects.

    Usable on its own in the user's loop: call :meth:`fill` with the energy [J] the loop dissipated
    over the last sample, then :meth:`pay` with the energy a stiffness change would inject; use
    the granted fraction of the change.

    What to fill with: the variable controllers fill the tank with the damper's ``Ts x̃̇ᵀ K_D x̃̇``
    capped by the energy the sampled loop really lost over that sample (the port's energy minus the
    rise of H at the held gains). The damper's estimate alone is the continuous loop's (9.32): a
    sampled loop, its torque held over each sample, loses up to about 14 % less (measured at
    k = 1e5 N/m, Ts = 1 ms), and with σ = 1 the tank then paid out energy that was never
    dissipated, so H + T grew by about Ts per second of contact.

    Args:
        initial: T₀ [J], ``minimum <= initial <= maximum``.
        minimum: T_min [J], >= 0: the tank never goes below it (a margin against round-off;
            the chapter's closed loop is passive with T_min = 0).
        maximum: T_max [J] (``inf`` allowed): energy above it is dropped, so a long run cannot
            bank unlimited energy for a later burst.
        dissipation_fraction: σ in [0, 1], the share of the damper's dissipated power stored.

    Attributes:
        energy: the current T [J].
        dropped: energy refused above T_max [J] (cumulative).
    """

    def __init__(self, initial: float = 1.0, *, minimum: float = 0.01, maximum: float = 10.0,
                 dissipation_fraction: float = 1.0) -> None:
        self.minimum = nonnegative_scalar("minimum", minimum, "J")
        # inf allowed (no cap); anything else a finite number >= 0, refused by name as initial and minimum are
        maximum = math.inf if isinstance(maximum, float) and maximum == math.inf else nonnegative_scalar(
            "maximum", maximum, "J")
        if not maximum > self.minimum:
            raise ParameterError(f"maximum must be > minimum = {self.minimum:.6g} J; got {maximum!r}")
        self.maximum = maximum
        self.initial = nonnegative_scalar("initial", initial)
        if not (self.minimum <= self.initial <= self.maximum):
            raise ParameterError(
                f"initial must lie in [minimum, maximum] = [{self.minimum:.6g}, {self.maximum:.6g}] J; got {initial!r}"
            )
        sigma = nonnegative_scalar("dissipation_fraction", dissipation_fraction)
        if sigma > 1.0:
            raise ParameterError(f"dissipation_fraction must be in [0, 1]; got {dissipation_fraction!r}")
        self.dissipation_fraction = sigma
        self.reset()

    def reset(self) -> None:
        """Back to T₀, nothing dropped."""
        self.energy = self.initial
        self.dropped = 0.0

    def fill(self, energy: float) -> None:
        """Store σ·``energy`` [J] (energy dissipated over the last sample, finite and >= 0); above T_max it is dropped."""
        if isinstance(energy, bool) or not isinstance(energy, (int, float, np.integer, np.floating)) \
                or not (math.isfinite(energy) and energy >= 0.0):
            raise ParameterError(f"energy to fill must be a finite number >= 0 J (dissipated energy); got {energy!r}")
        self._add(self.dissipation_fraction * energy)

    def pay(self, energy: float) -> float:
        """Pay ``energy`` [J] (< 0: energy returned to the tank); the fraction α ∈ [0, 1] granted.

        A positive request the tank cannot meet in full is granted the fraction
        ``α = (T − T_min) / energy`` and the tank is left at T_min; a negative one (the stiffness
        goes down) is always granted and refills the tank.
        """
        if not math.isfinite(energy):
            raise ParameterError(f"energy to pay must be finite; got {energy!r}")
        if energy <= 0.0:
            self._add(-energy)
            return 1.0
        available = self.energy - self.minimum
        if available >= energy:
            self.energy -= energy
            return 1.0
        self.energy = self.minimum
        return max(available, 0.0) / energy

    def _add(self, e: float) -> None:
        room = self.maximum - self.energy
        if e > room:
            self.dropped += e - room
            e = room
        self.energy += e


def _schedule_matrix(name: str, value: Any, m: int, t: float) -> np.ndarray:
    """A schedule's output as an (m, m) symmetric positive semi-definite matrix, or a clear error."""
    try:
        M = as_gain_matrix(name, value, m, definite=False)
    except (ParameterError, DimensionError) as exc:
        raise type(exc)(f"at t = {t:.6g} s, the {name} schedule returned an invalid gain: {exc}") from exc
    return M


class _Scheduled:
    """What both variable laws share: the schedules, the tank's bookkeeping and the signal log."""

    SIGNALS: ClassVar[tuple[str, ...]] = ("tank_energy", "stiffness_scale", "stiffness_refused", "storage")
    #: what each step appends; the scheduled K_s is kept to derive stiffness_scale and stiffness_refused in signals()
    _LOGGED = ("tank_energy", "storage", "stiffness", "damping", "scheduled")

    def _set_schedules(self, stiffness_schedule: Any, damping_schedule: Any, tank: Any, error: str) -> None:
        for name, f in (("stiffness_schedule", stiffness_schedule), ("damping_schedule", damping_schedule)):
            if f is not None and not callable(f):
                raise ParameterError(f"{name} must be a callable f(t, {error}) or None; got {f!r}")
        if tank is not None and not isinstance(tank, EnergyTank):
            raise ParameterError(f"tank must be an EnergyTank or None; got {type(tank).__name__}")
        self.stiffness_schedule = stiffness_schedule
        self.damping_schedule = damping_schedule
        self.tank = tank

    def _clear_log(self) -> None:
        self._log: dict[str, list[Any]] = {k: [] for k in self._LOGGED}
        if self.tank is not None:
            self.tank.reset()

    def _scheduled_gains(self, t: float, e: np.ndarray, ed: np.ndarray, K: np.ndarray, D: np.ndarray, m: int,
                         ed_prev: np.ndarray | None, loss: float | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(K applied, D applied, K scheduled) for this sample.

        With a tank: fill it with the energy dissipated over the last sample (None at the first one):
        the damper's ``Ts ėᵀ D ė`` at the error rate then (``ed_prev``, with the damping D then), but
        never more than ``loss``, the energy the sampled loop really lost (port energy minus the rise
        of H at the gains held over that sample; see :class:`EnergyTank`), then pay for
        ``½ eᵀ (K_s − K) e`` and move K by the fraction granted.
        """
        D_new = D if self.damping_schedule is None else _schedule_matrix(
            "damping", self.damping_schedule(t, e.copy(), ed.copy()), m, t)
        K_s = K if self.stiffness_schedule is None else _schedule_matrix(
            "stiffness", self.stiffness_schedule(t, e.copy(), ed.copy()), m, t)
        if self.tank is None:
            return np.array(K_s, dtype=np.float64), np.array(D_new, dtype=np.float64), K_s
        if ed_prev is not None:
            deposit = self.sample_time * float(ed_prev @ D @ ed_prev)  # type: ignore[attr-defined]
            if loss is not None:  # never more than the loop lost (nothing when it lost none, or the loss is unknown)
                deposit = min(deposit, loss) if loss > 0.0 else 0.0
            self.tank.fill(deposit)
        dK = K_s - K
        alpha = self.tank.pay(0.5 * float(e @ dK @ e)) if np.any(dK) else 1.0
        return K + alpha * dK, np.array(D_new, dtype=np.float64), K_s

    def _loss(self, port: float, e: np.ndarray, ed: np.ndarray, K_held: np.ndarray) -> float:
        """The energy the loop lost over the last sample: ``port`` (the energy in through the contact) minus the rise
        of H at the gains held over the sample, from the storage the last step recorded."""
        return port - (self._storage(e, ed, K_held) - self._log["storage"][-1])

    def _storage(self, e: np.ndarray, ed: np.ndarray, K: np.ndarray) -> float:
        """H = ½ ėᵀ M ė + ½ eᵀ K e [J] (M the controller's constant inertia)."""
        return 0.5 * float(ed @ self.inertia @ ed) + 0.5 * float(e @ K @ e)  # type: ignore[attr-defined]

    def _record(self, K: np.ndarray, K_s: np.ndarray, D: np.ndarray, storage: float) -> None:
        log = self._log
        log["tank_energy"].append(self.tank.energy if self.tank is not None else math.nan)
        log["storage"].append(storage)
        log["stiffness"].append(K.ravel().copy())
        log["damping"].append(D.ravel().copy())
        log["scheduled"].append(K_s.ravel().copy())

    def signals(self) -> dict[str, np.ndarray]:
        """What the controller logged at each step since the last reset (arrays, one row per step), with the
        applied stiffness against the scheduled one: ``stiffness_scale`` (trace ratio, 1 where the schedule's trace
        is 0) and ``stiffness_refused`` (‖K_s − K‖_F / ‖K_s‖_F, 0 where K_s = 0: the part of the schedule not
        applied, whatever its direction; a schedule that turns K keeps the trace)."""
        out = {k: np.asarray(v, dtype=np.float64) for k, v in self._log.items() if k != "scheduled"}
        K, K_s = out["stiffness"], np.asarray(self._log["scheduled"], dtype=np.float64)
        if K.size == 0:
            out["stiffness_scale"] = out["stiffness_refused"] = np.zeros(0)
            return out
        m = math.isqrt(K.shape[1])
        tr_s = np.trace(K_s.reshape(-1, m, m), axis1=1, axis2=2)
        tr = np.trace(K.reshape(-1, m, m), axis1=1, axis2=2)
        size = np.linalg.norm(K_s, axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):
            out["stiffness_scale"] = np.where(tr_s > 0.0, tr / tr_s, 1.0)
            out["stiffness_refused"] = np.where(size > 0.0, np.linalg.norm(K_s - K, axis=1) / size, 0.0)
        return out


class VariableImpedanceController(_Scheduled, ImpedanceController):
    """Impedance control with force measurement (9.30)–(9.31) whose K_P and K_D follow schedules.

    Law: as :class:`ImpedanceController` with force measurement,
    ``a = ẍ_d + M_d⁻¹ (K_D(t) x̃̇ + K_P(t) x̃ − h_A)``, closed loop (9.32) with time-varying gains.
    With a ``tank`` (:class:`EnergyTank`), each sample the tank is filled with σ times the energy
    dissipated over the last sample (the damper's ``Ts x̃̇ᵀ K_D x̃̇``, at most the port's energy
    ``½ (h_k + h_{k+1})ᵀ (x̃_{k+1} − x̃_k)`` minus the rise of H at the held gains), and the stiffness moves from its
    last value K towards the scheduled K_s by the fraction α the tank grants for
    ``ΔE = ½ x̃ᵀ (K_s − K) x̃``: ``K ← K + α (K_s − K)``. Without a tank the schedule is applied as
    asked (the naive law, not passive).

    Logged signals (``signals()``; in a simulation, ``result.signals``): ``tank_energy`` [J]
    (NaN without a tank), ``stiffness_scale`` (trace of the applied K_P over the trace of the
    scheduled one: how much of the scheduled size is applied), ``stiffness_refused``
    (‖K_s − K_P‖_F / ‖K_s‖_F: the part of the schedule the tank refused, in any direction, 0 when it
    is applied as asked; a schedule that turns K_P keeps the trace ratio at 1 while it is refused),
    ``storage`` H [J] and ``stiffness`` / ``damping`` (the applied matrices, flattened per sample).

    Args:
        robot: the manipulator (position task space, as :class:`ImpedanceController`).
        inertia: M_d (m, m) [kg], constant.
        damping, stiffness: K_D and K_P (m, m) at t = 0 (scalar, (m,) diagonal or (m, m)); they
            are used when the corresponding schedule is None.
        stiffness_schedule, damping_schedule: ``f(t, x_tilde, x_tilde_dot)`` returning the gain
            wanted at time t for the current errors (scalar, (m,) or (m, m), symmetric positive
            semi-definite); None: constant.
        tank: an :class:`EnergyTank` (passive law) or None (naive law).
        sample_time: Ts [s]; posture, singularity: as :class:`ImpedanceController`.

    Raises:
        ParameterError: a schedule is not callable, or returns a non-symmetric, indefinite or
            non-finite gain (at the step, naming t).
    """

    def __init__(
        self, robot: RobotModel, inertia: Any, damping: Any, stiffness: Any, *,
        stiffness_schedule: Schedule | None = None, damping_schedule: Schedule | None = None,
        tank: EnergyTank | None = None, sample_time: float = 1e-3, posture: Any = None, singularity: Any = None,
    ) -> None:
        super().__init__(robot, inertia, damping, stiffness, True, sample_time, posture=posture, singularity=singularity)
        self._compiled = False  # the gains change every step: the law runs with the gains repacked each sample
        self._set_schedules(stiffness_schedule, damping_schedule, tank, "x_tilde, x_tilde_dot")
        self.reset()

    def reset(self, measurement: Measurement | None = None, reference: Reference | None = None) -> None:
        """Gains back to their initial values, the tank to T₀, the signal log emptied."""
        self._K = np.array(self.stiffness, dtype=np.float64)
        self._D = np.array(self.damping, dtype=np.float64)
        self._last_xtd: np.ndarray | None = None
        self._clear_log()

    @property
    def current_stiffness(self) -> np.ndarray:
        """The K_P applied at the last step (m, m) [N/m]."""
        return self._K.copy()

    @property
    def current_damping(self) -> np.ndarray:
        """The K_D applied at the last step (m, m) [N s/m]."""
        return self._D.copy()

    def step(self, t: float, measurement: Measurement, reference: Reference) -> np.ndarray:
        """Torques of (9.30)–(9.31) with the gains of this sample (tank-limited when there is a tank)."""
        from .hybrid import _frame_pose, _on_arm_step

        T, x, xd = _frame_pose(self, measurement)  # the chapter's arm: x, ẋ alone, the law in one compiled call
        xt = np.asarray(reference.position, dtype=np.float64) - x
        xtd = np.asarray(reference.velocity, dtype=np.float64) - xd
        loss = None
        if self.tank is not None:
            h = np.asarray(measurement.wrench, dtype=np.float64)[: self.m]
            if self._last_xtd is not None:  # the port's energy: the trapezoid of h_A over the error's step
                loss = self._loss(0.5 * float((h + self._last_h) @ (xt - self._last_xt)), xt, xtd, self._K)
            self._last_xt, self._last_h = xt, h
        K, D, K_s = self._scheduled_gains(t, xt, xtd, self._K, self._D, self.m, self._last_xtd, loss)
        self._K, self._D, self._last_xtd = K, D, xtd
        self._params[IMPEDANCE.slice("K_D", self.m)] = np.ravel(D)
        self._params[IMPEDANCE.slice("K_P", self.m)] = np.ravel(K)
        if T is None and self._law_plain():
            u = _on_arm_step(self, t, measurement, reference, self._params)
        else:
            u = self._law_step(t, measurement, reference, T)
        self._record(K, K_s, D, self._storage(xt, xtd, K))
        return u

    def _law_plain(self) -> bool:
        """The law runs as such (no singularity handling, no posture: ``_law_step``'s square branch)."""
        return getattr(self, "singularity", None) is None and getattr(self, "posture", None) is None

    def gains(self) -> dict[str, Any]:
        g = super().gains()
        g.update({
            "stiffness_schedule": getattr(self.stiffness_schedule, "__name__", repr(self.stiffness_schedule)),
            "damping_schedule": getattr(self.damping_schedule, "__name__", repr(self.damping_schedule)),
            "tank": None if self.tank is None else {
                "initial": self.tank.initial, "minimum": self.tank.minimum, "maximum": self.tank.maximum,
                "dissipation_fraction": self.tank.dissipation_fraction,
            },
        })
        return g



class VariableAdmittanceController(_Scheduled, AdmittanceController):
    """Admittance control (9.37) whose compliant-frame stiffness K_Pt and damping K_Dt follow schedules.

    The compliant frame's dynamics ``M_t z̃̈ + K_Dt z̃̇ + K_Pt z̃ = h_e^d`` are the controller's own
    (a virtual system), with storage ``H_t = ½ z̃̇ᵀ M_t z̃̇ + ½ z̃ᵀ K_Pt z̃``; a stiffness change
    injects ``½ z̃ᵀ ΔK_Pt z̃`` into it. With an :class:`EnergyTank` the change is paid from the
    energy the virtual damper dissipated over the last sample (``σ Ts z̃̇ᵀ K_Dt z̃̇``, at most the
    held input's energy ``h_kᵀ (z̃_{k+1} − z̃_k)`` minus the rise of H_t at the held gains), scaled down
    when the tank cannot pay, exactly as :class:`VariableImpedanceController` does; the
    discretisation of (9.37) is recomputed whenever the gains change. The motion loop that tracks
    the compliant frame is unchanged.

    Logged signals (``signals()``): ``tank_energy`` [J] (NaN without a tank),
    ``stiffness_scale``, ``stiffness_refused`` (as :class:`VariableImpedanceController`'s), ``storage`` H_t [J],
    ``stiffness`` and ``damping`` (flattened 6 × 6).

    Args:
        robot, inertia, damping, stiffness: as :class:`AdmittanceController` (the gains at t = 0).
        stiffness_schedule, damping_schedule: ``f(t, z_tilde, z_tilde_dot)`` (z̃ (6,) in
            desired-frame coordinates) returning a scalar, (6,) or (6, 6) PSD gain; None: constant.
        tank: an :class:`EnergyTank` or None (naive).
        **kwargs: the other :class:`AdmittanceController` options.
    """

    def __init__(self, robot: RobotModel, inertia: Any, damping: Any, stiffness: Any, *,
                 stiffness_schedule: Schedule | None = None, damping_schedule: Schedule | None = None,
                 tank: EnergyTank | None = None, **kwargs: Any) -> None:
        super().__init__(robot, inertia, damping, stiffness, **kwargs)
        self._set_schedules(stiffness_schedule, damping_schedule, tank, "z_tilde, z_tilde_dot")
        self._K0, self._D0 = self.stiffness, self.damping
        self.reset()

    def reset(self, measurement: Measurement | None = None, reference: Reference | None = None) -> None:
        """The compliant frame on the desired frame at rest, the gains and tank back to their start, the log emptied."""
        super().reset(measurement, reference)
        if not hasattr(self, "_K0"):
            return  # called by the base constructor before this class's attributes exist
        if self.stiffness is not self._K0 or self.damping is not self._D0:
            self.stiffness, self.damping = self._K0, self._D0
            self._discretise()
        self._last_zd: np.ndarray | None = None
        self._clear_log()

    def step(self, t: float, measurement: Measurement, reference: Reference) -> np.ndarray:
        """Update the gains of (9.37) (tank-limited), then the admittance law for this sample."""
        z, zd = self.state[:6].copy(), self.state[6:].copy()
        loss = None
        if self._last_zd is not None and self.tank is not None:  # the port's energy: its input held over the sample
            loss = self._loss(float(self._last_hd @ (z - self._last_z)), z, zd, self.stiffness)
        K, D, K_s = self._scheduled_gains(t, z, zd, self.stiffness, self.damping, 6, self._last_zd, loss)
        self._last_zd, self._last_z = zd, z
        if not (np.array_equal(K, self.stiffness) and np.array_equal(D, self.damping)):
            self.stiffness, self.damping = K, D
            self._discretise()
        self._record(K, K_s, D, self._storage(z, zd, K))
        u = super().step(t, measurement, reference)
        self._last_hd = self.held_wrench
        return u
