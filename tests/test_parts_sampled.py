"""The sampled-loop verdict of `analyze` on impedance and compliance cases, against scratch models and simulation.

References: the one-axis loop along a plane's normal and the free axis written from scratch
(tests/sampled_helpers.py), and ``run_scenario`` on the full nonlinear arm: Example 9.2 at a
stiffness the analysis flags bounces off the plane, 10 % below its limit it keeps the contact and
its oscillation decays at the rate the end pose's spectral radius predicts; the command as a user
runs it (a subprocess) warns on stderr and in --json.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from forcecontrol.scenarios import build_case, case_analysis, load_scenario, run_scenario
from forcecontrol.scenarios.core import contact_losses
from forcecontrol.scenarios.report import analyze_scenario
from forcecontrol.scenarios.units import unit
from journeys_helpers import forcecontrol
from sampled_helpers import KD, KP, MD, Q0, TS, free_axis_radius, mobility, one_axis_radius, plane_normal

EXAMPLE_9_2 = load_scenario("example-9.2")


def _toml(stiffness: float, *, angle: float | None = None, label: str = "stiff plane", depth: float = 0.1,
          force_measurement: bool = True, duration: float = 4.0) -> str:
    """Example 9.2's arm and gains on a plane through [1, 0] (normal −x, or at ``angle`` degrees), x_d ``depth`` inside."""
    n = np.array([-1.0, 0.0]) if angle is None else plane_normal(angle)
    x_d = np.array([1.0, 0.0]) - depth * n
    plane = 'normal = [-1.0, 0.0]' if angle is None else f"angle = {angle}"
    return f"""name = "sampled-check"
duration = {duration}
sample_time = {TS}

[robot]
model = "chapter-arm"
start_position = [1.0, 0.0]
elbow = "up"

[environment]
type = "elastic-plane"
point = [1.0, 0.0]
{plane}
stiffness = {float(stiffness)!r}

[controller]
type = "impedance"
force_measurement = {str(force_measurement).lower()}
inertia = [{MD}, {MD}]
damping = [{KD}, {KD}]
stiffness = [{KP}, {KP}]

[reference]
type = "setpoint"
position = [{float(x_d[0])!r}, {float(x_d[1])!r}]

[[case]]
label = "{label}"
"""


def _scenario(tmp_path, **kw):
    path = tmp_path / "case.toml"
    path.write_text(_toml(**kw), encoding="utf-8")
    return load_scenario(str(path))


def test_example_9_2_reports_the_radius_of_each_axis_the_limit_and_no_warning():
    """The book's cases (k = 1e4, 1e3 N/m): ρ_x, ρ_y < 1 from the scratch models, a limit near 2.2e6 N/m, no warning."""
    mu = float(mobility(Q0)[0, 0])
    for case, k in zip(analyze_scenario("example-9.2")["cases"], (1e4, 1e3)):
        a = case["analysis"]
        assert a["spectral_radius_x"] == pytest.approx(one_axis_radius(k, mu), rel=1e-9)
        assert a["spectral_radius_y"] == pytest.approx(free_axis_radius(), rel=1e-9)
        assert a["end_spectral_radius_x"] < 1.0 and a["end_spectral_radius_y"] < 1.0
        assert 2.0e6 < a["stability_limit_x"] < 2.3e6 and "stability_limit_y" not in a
        assert not [w for w in case["warnings"] if w["kind"] == "sampled-unstable"]
        assert "sampled_loop_skipped" not in case


@pytest.mark.parametrize("angle", [30.0, 60.0])
@pytest.mark.parametrize("k", [1e4, 1e6, 1e8])
def test_a_tilted_plane_case_couples_x_and_y_with_the_scratch_radius(tmp_path, angle, k):
    """A plane at 30° and 60°: spectral_radius_x = _y = max(normal axis, free tangent axis) at q0; the same limit on both."""
    n = plane_normal(angle)
    parts = build_case(_scenario(tmp_path, stiffness=k, angle=angle).cases[0], where="test")
    a = case_analysis(parts)
    ref = max(one_axis_radius(k, float(n @ mobility(Q0) @ n)), free_axis_radius())
    assert a["spectral_radius_x"] == pytest.approx(ref, rel=1e-9)
    assert a["spectral_radius_y"] == pytest.approx(ref, rel=1e-9)
    assert a["stability_limit_x"] == a["stability_limit_y"]
    # the limit: the scratch model along the normal crosses 1 there (at q0), or earlier at the end pose
    assert one_axis_radius(a["stability_limit_x"], float(n @ mobility(Q0) @ n)) < 1.0 + 1e-9


def test_without_force_measurement_9_28_gets_its_radius_too(tmp_path):
    """(9.28) on Example 9.2's plane: the radius along x is the scratch (9.28) loop's (nothing cancelled within a sample)."""
    k = 1e6
    parts = build_case(_scenario(tmp_path, stiffness=k, force_measurement=False).cases[0], where="test")
    a = case_analysis(parts)
    assert a["spectral_radius_x"] == pytest.approx(one_axis_radius(k, float(mobility(Q0)[0, 0]), "9.28"), rel=1e-9)
    assert a["spectral_radius_x"] < 1.0 and "omega_n_x" not in a  # no continuous model of (9.29) is claimed


def test_compliance_cases_get_a_coupled_radius():
    """Example 9.1 (active compliance, (8.110)): x and y are one loop through the mobility, stable, with a limit."""
    for case in analyze_scenario("example-9.1")["cases"]:
        a = case["analysis"]
        assert a["spectral_radius_x"] == a["spectral_radius_y"] < 1.0
        assert a["stability_limit_x"] > 1e8
        assert not [w for w in case["warnings"] if w["kind"] == "sampled-unstable"]


def _run(k: float, *, duration: float = 10.0, position=None):
    changes = {"environment.stiffness": k, "duration": duration}
    if position is not None:
        changes["reference.position"] = position
    scn = EXAMPLE_9_2.with_(changes)
    return analyze_scenario(scn)["cases"][0], run_scenario(scn).cases[0].result


def _peak_to_peak(f: np.ndarray, t: np.ndarray, t0: float, t1: float) -> float:
    sel = (t >= t0) & (t < t1)
    return float(np.ptp(f[sel]))


def test_example_9_2_at_1e9_is_flagged_and_bounces_in_simulation():
    """k = 1e9 N/m: ρ_x ≈ 1.45 >= 1 (ω_n·T ≈ 3.16) is a sampled-unstable warning naming x, and the arm bounces."""
    case, res = _run(1e9, duration=4.0)
    warn = [w for w in case["warnings"] if w["kind"] == "sampled-unstable"]
    assert len(warn) == 1 and warn[0]["axes"] == ["x"]
    assert warn[0]["spectral_radius"] == pytest.approx(1.4546, abs=1e-4)
    assert warn[0]["omega_n_T"] == pytest.approx(math.sqrt((KP + 1e9) / MD) * TS, rel=1e-9)
    assert {"steady_fx", "omega_n_x", "zeta_x"} <= set(warn[0]["quantities"]) and "omega_n_y" not in warn[0]["quantities"]
    assert contact_losses(res.wrench) > 5


@pytest.fixture(scope="module")
def limit() -> float:
    """Example 9.2's predicted limit along x (the end pose's: about 2.23e6 N/m)."""
    value = analyze_scenario(EXAMPLE_9_2.with_({"environment.stiffness": 1e9}))["cases"][0]["analysis"]["stability_limit_x"]
    assert value == pytest.approx(2.2306e6, rel=1e-3)
    return value


def test_ten_percent_below_the_limit_the_contact_holds_and_decays_at_the_predicted_rate(limit):
    """0.9 × limit: no warning, no contact loss in 10 s, and the contact-force oscillation's envelope shrinks as
    ρ_end^(t/T) (within 10 % in rate): the sampled model at the pose where the arm ends."""
    case, res = _run(0.9 * limit)
    a = case["analysis"]
    assert a["spectral_radius_x"] < 1.0 and a["end_spectral_radius_x"] < 1.0
    assert not [w for w in case["warnings"] if w["kind"] == "sampled-unstable"]
    assert contact_losses(res.wrench) == 0
    f, t = res.wrench[:, 0], res.t
    rate = math.log(_peak_to_peak(f, t, 9.0, 10.0) / _peak_to_peak(f, t, 1.0, 2.0)) / 8.0
    assert rate == pytest.approx(math.log(a["end_spectral_radius_x"]) / TS, rel=0.1)
    assert rate < -0.2  # settling: the oscillation shrinks by e every 4 s or faster


def test_ten_percent_above_the_limit_it_is_flagged_and_bounces(limit):
    """1.1 × limit: flagged (the end pose's ρ >= 1 although q0's is < 1) and the arm loses the contact again and again."""
    case, res = _run(1.1 * limit)
    a = case["analysis"]
    assert a["spectral_radius_x"] < 1.0 <= a["end_spectral_radius_x"]
    warn = [w for w in case["warnings"] if w["kind"] == "sampled-unstable"]
    assert len(warn) == 1 and warn[0]["end_spectral_radius"] >= 1.0
    assert contact_losses(res.wrench) > 10


@pytest.mark.parametrize(("ratio", "bounces"), [(0.95, False), (1.05, True)])
def test_without_motion_along_the_plane_the_start_pose_limit_holds_within_5_percent(ratio, bounces):
    """x_d = [1.1, 0]: the arm stays at q0, end = start pose; 5 % below q0's limit (about 2.59e6 N/m) it holds, 5 % above
    it bounces."""
    start = analyze_scenario(EXAMPLE_9_2.with_({"environment.stiffness": 1e9, "reference.position": [1.1, 0.0]}))
    lim = start["cases"][0]["analysis"]["stability_limit_x"]
    assert lim == pytest.approx(2.592e6, rel=1e-3)
    case, res = _run(ratio * lim, position=[1.1, 0.0])
    assert bool([w for w in case["warnings"] if w["kind"] == "sampled-unstable"]) is bounces
    assert (contact_losses(res.wrench) > 0) is bounces


def test_cases_without_a_sampled_verdict_say_why():
    """A scheduled impedance and the hybrid compliant scheme give ω_n, ζ without a sampled verdict: the case says so."""
    variable = analyze_scenario("variable-stiffness")["cases"]
    assert all("schedule" in c["sampled_loop_skipped"] for c in variable)
    # its predicted steady state is the t = 0 gains' (the naive case bounces to 1634 N; the tank one ends near 26 N)
    assert all("steady state" in c["sampled_loop_skipped"] and "t = 0" in c["sampled_loop_skipped"] for c in variable)
    hybrid = analyze_scenario("example-9.4")["cases"]
    assert all("hybrid" in c["sampled_loop_skipped"] for c in hybrid)
    assert all("sampled_loop_skipped" not in c for c in analyze_scenario("example-9.3")["cases"])


def test_a_6d_case_says_it_has_no_sampled_verdict():
    """Panda admittance on a table (6-D): nothing added to its analysis, and the case says why."""
    pytest.importorskip("pinocchio")
    case = analyze_scenario("panda-admittance-contact")["cases"][0]
    assert not any("spectral_radius" in k for k in case["analysis"])
    assert "6-D" in case["sampled_loop_skipped"]


def test_a_case_without_q0_gets_no_sampled_keys():
    """Parts built by hand without q0 (no pose, no mobility): the other analyses only, nothing raised."""
    parts = build_case(EXAMPLE_9_2.cases[0], where="test")
    del parts["q0"]
    a = case_analysis(parts)
    assert "omega_n_x" in a and not any("spectral_radius" in k for k in a)


def test_units_of_the_new_quantities():
    """spectral_radius_x and end_spectral_radius_x are dimensionless, stability_limit_x [N/m]."""
    assert unit("spectral_radius_x") == "-" and unit("end_spectral_radius_y") == "-" and unit("stability_limit_x") == "N/m"


def test_the_command_warns_on_stderr_and_in_json(tmp_path):
    """`forcecontrol analyze FILE` (k = 1e9 N/m) exits 0 with a warning line naming the case, axis x, ρ and ω_n·T on
    stderr, † on the table; `--json` has spectral_radius_x >= 1 and the sampled-unstable warning."""
    (tmp_path / "stiff.toml").write_text(_toml(1e9, label="k = 1e9"), encoding="utf-8")
    table = forcecontrol(tmp_path, "analyze", "stiff.toml")
    lines = [ln for ln in table.stderr.splitlines() if ln.startswith("warning: ")]
    assert len(lines) == 1, table.stderr
    assert lines[0].startswith("warning: k = 1e9: the sampled loop is unstable along axis x (ρ = 1.4546")
    assert "ω_n·T = 3.162" in lines[0] and "not reached" in lines[0]
    assert "UNSTABLE" in table.stdout and "steady_fx [N] †" in table.stdout
    js = forcecontrol(tmp_path, "analyze", "stiff.toml", "--json")
    assert any(ln.startswith("warning: k = 1e9: the sampled loop is unstable") for ln in js.stderr.splitlines())
    case = json.loads(js.stdout)["cases"][0]
    assert case["analysis"]["spectral_radius_x"] >= 1.0
    assert [w["kind"] for w in case["warnings"]] == ["sampled-unstable"]
    assert json.loads(js.stdout)["units"]["end_spectral_radius_x"] == "-"


def test_a_servo_or_vendor_loop_beyond_its_limit_is_a_sampled_unstable_warning_too():
    """The position-interface servo loop and the vendor controllers' loops have one spectral radius for the whole loop:
    >= 1 is the same warning, without axes. servo-admittance's second case is its 'beyond the limit: bounces' (its
    file expects servo_loop_stable = 0), FZI issue #21's 'reported' case shakes as reported upstream; the stable
    cases of both say nothing."""
    from importlib import resources

    servo = analyze_scenario("servo-admittance")["cases"]
    fzi = analyze_scenario(str(resources.files("forcecontrol.scenarios") / "configs" / "fzi_issue_21.toml"))["cases"]
    for case, unstable in ((servo[0], False), (servo[1], True), (fzi[0], True), (fzi[1], False)):
        warn = [w for w in case["warnings"] if w["kind"] == "sampled-unstable"]
        key = next(k for k in case["analysis"] if k.endswith("loop_spectral_radius"))
        assert (case["analysis"][key] >= 1.0) is unstable
        assert bool(warn) is unstable, case["label"]
        if unstable:
            w = warn[0]
            assert w["axes"] == [] and w["spectral_radius"] == case["analysis"][key]
            assert "is unstable" in w["text"] and case["label"] in w["text"]
            limit = case["analysis"][key.replace("spectral_radius", "stability_limit")]
            assert f"{limit:.6g}" in w["text"]
            assert {k for k in case["analysis"] if k.startswith("steady_")} <= set(w["quantities"])
