"""The ``forcecontrol design`` command: gains for a stiffness range (registered in :mod:`forcecontrol.cli`)."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated

import typer

from .app import _fail, print_json

__all__ = ["design_command"]


def design_command(
    scheme: Annotated[
        str, typer.Argument(help="impedance, inner-position, inner-velocity, parallel, hybrid, admittance-position, "
                                 "or a vendor controller: fzi-compliance, fzi-force, ros2-admittance, ur-force-mode (--config)")
    ],
    k_min: Annotated[float, typer.Option("--k-min", help="lowest environment stiffness [N/m]")],
    k_max: Annotated[float, typer.Option("--k-max", help="highest environment stiffness [N/m]")],
    sample_time: Annotated[
        float | None, typer.Option(help="control period Ts [s] (default 0.001; admittance-position: the servo step, 1/(4 rate))")
    ] = None,
    delay: Annotated[
        int | None,
        typer.Option(help="sensor delay [samples] (default 0; admittance-position: transport delay [cycles], default 1)"),
    ] = None,
    filter_cutoff: Annotated[float | None, typer.Option(help="sensor first-order filter cutoff [Hz] (default: none)")] = None,
    phase_margin: Annotated[float, typer.Option(help="required phase margin [deg]")] = 45.0,
    gain_margin: Annotated[float, typer.Option(help="required gain margin [dB]")] = 6.0,
    settling_time: Annotated[
        float | None, typer.Option(help="required worst-case 2 % settling time [s] (default: as fast as the margins allow)")
    ] = None,
    damping_ratio: Annotated[float, typer.Option(help="ζ of the placed poles (force schemes, hybrid)")] = 0.8,
    inertia: Annotated[float, typer.Option(help="M_d / m_d [kg]")] = 100.0,
    stiffness: Annotated[float, typer.Option(help="K_P / k_P [N/m] (the task's choice, kept)")] = 2500.0,
    arm_inertia: Annotated[float | None, typer.Option(help="the arm's operational mass along the axis [kg]")] = None,
    rate: Annotated[float | None, typer.Option(
        help="admittance-position and vendor schemes: interface rate [Hz] (default 500; a vendor --config file's own "
             "update_rate when it gives one)")] = None,
    servo_bandwidth: Annotated[float, typer.Option(help="admittance-position: joint servo ω_s [rad/s]")] = 44.7,
    servo_damping: Annotated[float, typer.Option(help="admittance-position: joint servo ζ_s")] = 0.67,
    lowpass_cutoff: Annotated[
        float | None, typer.Option(help="admittance-position: command low-pass [Hz] (default: none)")
    ] = None,
    robot: Annotated[
        str, typer.Option(help="admittance-position: the --out scenario's robot: chapter-arm, ur5 or panda")
    ] = "chapter-arm",
    config: Annotated[Path | None, typer.Option(
        help="vendor schemes: the controller's own file (YAML, .cfg, UR script) to tune; --out writes it back")] = None,
    solver: Annotated[str | None, typer.Option(
        help="fzi schemes: the solver the arm runs, accumulating (default) or instantaneous (before Dec 2021)")] = None,
    out: Annotated[Path | None, typer.Option(
        help="write a scenario (TOML) with one case per checked stiffness; vendor schemes: the tuned --config file")] = None,
    force: Annotated[bool, typer.Option("--force", help="overwrite --out if it exists")] = False,
    json_out: Annotated[bool, typer.Option("--json", help="print one JSON object instead of a table")] = False,
) -> None:
    """Gains that keep a phase and gain margin over [k_min, k_max], with sampling, sensor delay and filter.

    Prints the gains and, at k_min, √(k_min k_max) and k_max, the margins and 2 % settling time of
    the sampled loop (see forcecontrol.analysis.design); --out writes a runnable scenario.
    """
    import math

    from ..analysis.design import DESIGN_SCHEMES
    from ..errors import ForceControlError, OutputError, ParameterError
    from .design_vendor import VENDOR_SCHEMES, design_vendor

    schemes = (*DESIGN_SCHEMES, "admittance-position", *VENDOR_SCHEMES)
    if scheme not in schemes:  # every scheme the command designs, not one analysis' list
        _fail(ParameterError(f"SCHEME must be one of {', '.join(schemes)}; got {scheme!r}"))
    if not (0 < k_min <= k_max < math.inf):  # named as the user typed them
        _fail(ParameterError(f"--k-min and --k-max must satisfy 0 < k_min <= k_max < inf; got {k_min:g}, {k_max:g}"))
    if scheme in VENDOR_SCHEMES:
        design_vendor(scheme, config, k_min, k_max, rate=rate, servo_bandwidth=servo_bandwidth, servo_damping=servo_damping,
                      delay=delay, gain_margin=gain_margin, solver=solver, out=out, force=force, json_out=json_out)
        return
    try:
        from ..analysis.gain_design import design_gains

        servo_opts = {"--rate": rate is not None, "--servo-bandwidth": servo_bandwidth != 44.7,
                      "--servo-damping": servo_damping != 0.67, "--lowpass-cutoff": lowpass_cutoff is not None,
                      "--robot": robot != "chapter-arm"}
        other_opts = {"--filter-cutoff": filter_cutoff is not None, "--arm-inertia": arm_inertia is not None}
        if config is not None or solver is not None:
            raise ParameterError(f"--config and --solver are for the vendor schemes ({', '.join(VENDOR_SCHEMES)}); "
                                 f"the scheme is {scheme!r}")
        unused = [k for k, v in (other_opts if scheme == "admittance-position" else servo_opts).items() if v]
        if unused:  # an option the scheme does not read is refused, not silently ignored
            raise ParameterError(
                f"{', '.join(unused)} {'does' if len(unused) == 1 else 'do'} not apply to the {scheme} scheme; "
                + ("--rate, --servo-bandwidth, --servo-damping, --lowpass-cutoff and --robot are for admittance-position"
                   if scheme != "admittance-position" else "admittance-position reads no sensor filter or arm inertia")
            )
        if scheme == "admittance-position":  # (9.37) behind a position-interface arm's servo (analysis.servo_design)
            from ..analysis.servo_design import design_admittance_servo

            d = design_admittance_servo(
                (k_min, k_max), rate=500.0 if rate is None else rate, servo_bandwidth=servo_bandwidth,
                servo_damping=servo_damping,
                delay_cycles=1 if delay is None else delay, lowpass_cutoff=lowpass_cutoff, inertia=inertia, stiffness=stiffness,
                phase_margin=phase_margin, gain_margin=gain_margin, settling_time=settling_time, robot=robot,
                sample_time=sample_time,
            )
        else:
            d = design_gains(
                scheme, (k_min, k_max), 1e-3 if sample_time is None else sample_time, delay_samples=delay or 0,
                filter_cutoff=filter_cutoff, phase_margin=phase_margin, gain_margin=gain_margin,
                settling_time=settling_time, damping_ratio=damping_ratio, inertia=inertia, stiffness=stiffness,
                arm_inertia=arm_inertia,
            )
        written = None
        if out is not None:
            if out.exists() and not force:
                raise OutputError(f"{str(out)!r} exists; pass --force to overwrite it")
            try:
                out.parent.mkdir(parents=True, exist_ok=True)
                out.write_text(d.scenario_toml(name=out.stem), encoding="utf-8")
            except OSError as exc:
                raise OutputError(f"cannot write {str(out)!r}: {exc.strerror or exc}") from exc
            written = str(out)
    except ForceControlError as exc:
        _fail(_named_as_typed(exc))
    from ..scenarios.units import design_gain_unit, unit

    gain_units = {name: design_gain_unit(scheme, name) for name in d.gains}
    if json_out:
        doc = d.as_dict()
        names = {"stiffness_range", *(k for c in doc["checks"] for k in c), *doc["requirements"]}
        units = {n: u for n in sorted(names) if (u := unit(n))}
        # gains share names with requirements in no scheme; a gain's unit depends on the scheme
        print_json({**doc, "scenario": written, "units": {**units, **{f"gains.{k}": u for k, u in gain_units.items() if u}}})
        return
    from rich.console import Console
    from rich.table import Table

    from .safe import escape

    console = Console(width=None if sys.stdout.isatty() else 132)
    g = Table(title=f"{scheme} gains for k in [{k_min:g}, {k_max:g}] N/m", title_justify="left")
    g.add_column("gain")
    g.add_column("value", justify="right")
    for name, v in d.gains.items():
        g.add_row(escape(f"{name} [{gain_units[name]}]" if gain_units[name] else name), f"{v:.6g}")
    console.print(g)
    c = Table(title="the sampled loop at the ends and the middle of the range", title_justify="left")
    for col in ("k [N/m]", "phase margin [deg]", "gain margin [dB]", "settling 2 % [s]", "spectral radius"):
        c.add_column(escape(col), justify="right")  # '[s]', '[deg]' are units, not rich markup
    for row in d.checks:
        c.add_row(f"{row['k']:.6g}", f"{row['phase_margin_deg']:.1f}", f"{row['gain_margin_db']:.1f}",
                  f"{row['settling_time']:.4g}", f"{row['spectral_radius']:.4f}")
    console.print(c)
    if written:
        console.print(f"scenario: {written}  (run it: forcecontrol run {written})")


#: the design functions' parameter names → the options a user typed (an error names what was typed)
_OPTIONS = {"sample_time": "--sample-time", "delay_samples": "--delay", "delay_cycles": "--delay",
            "filter_cutoff": "--filter-cutoff", "phase_margin": "--phase-margin", "gain_margin": "--gain-margin",
            "settling_time": "--settling-time", "damping_ratio": "--damping-ratio", "inertia": "--inertia",
            "stiffness": "--stiffness", "arm_inertia": "--arm-inertia", "rate": "--rate",
            "servo_bandwidth": "--servo-bandwidth", "servo_damping": "--servo-damping", "lowpass_cutoff": "--lowpass-cutoff"}


def _named_as_typed(exc: Exception) -> Exception:
    """The library's error with the parameter it names at its start written as the command's option
    (``arm_inertia must be a positive number`` → ``--arm-inertia must be ...``); other errors unchanged."""
    text = str(exc)
    name = text.split(" ", 1)[0]
    if name in _OPTIONS and text.startswith(f"{name} must"):
        return type(exc)(_OPTIONS[name] + text[len(name):])
    return exc
