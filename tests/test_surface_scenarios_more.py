"""Issue 31 item 4: wiping an unknown bump field and a spiral search for a hole, against analysis/surface_following.py
and closed forms (BumpField's geometry, the Archimedean spiral, the dip's detection radius)."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from forcecontrol.analysis.surface_following import path_following_bound
from forcecontrol.environments.heightfield_extra import BumpField
from forcecontrol.scenarios import load_scenario, run_scenario
from forcecontrol.scenarios.build import build_case
from forcecontrol.scenarios.parts_surface_tasks import spiral_reference, wipe_line_reference

TS = 1e-3


def test_bump_field_geometry_is_the_formula():
    """Above a crest φ = z − h, ν = z; the normal curvature there is −A k² (convex) and +A k² in a trough (closed form)."""
    A, L = 0.005, 0.2
    f = BumpField([0.0, -0.05], 0.005, [41, 21], 0.1, A, L, [0.05, 0.0], stiffness=1e4)
    phi, pc, nu = f.geometry(np.array([0.05, 0.0, 0.1 + A + 0.01]))
    assert phi == pytest.approx(0.01, abs=1e-12)
    np.testing.assert_allclose(nu, [0.0, 0.0, 1.0], atol=1e-12)
    k = 2 * math.pi / L
    assert f.path_curvature(0.05, 0.0, [1.0, 0.0]) == pytest.approx(-A * k * k, rel=1e-12)
    assert f.path_curvature(0.15, 0.0, [1.0, 0.0]) == pytest.approx(A * k * k, rel=1e-12)
    # off the crest: p_c is the foot of the perpendicular (p − p_c along ν) and φ its signed length
    p = np.array([0.08, 0.01, 0.1])
    phi, pc, nu = f.geometry(p)
    np.testing.assert_allclose(p - pc, phi * nu, atol=1e-12)
    assert pc[2] == pytest.approx(f.height(pc[:2]), abs=1e-15)


def test_the_compiled_projection_lands_on_the_formulas_surface_along_its_normal():
    """The contact's compiled projection (dips included), at 2000 points within 5 mm of the surface: p_c is on the
    surface of the Python formula (``height_formula``) to the bit, ν is that formula's normal, and p − p_c = φ ν
    is orthogonal to both tangents (1, 0, h_x) and (0, 1, h_y) (the optimality of the closest point). Within 5 mm:
    a contact's depth (10 N on 10⁴ N/m is 1 mm); Gauss–Newton converges at the rate |φ| κ, 0.15 here in the
    sharpest dip (κ = d/w² = 30 m⁻¹)."""
    f = BumpField([0.0, -0.05], 0.005, [41, 21], 0.1, 0.004, 0.15, [0.03, 0.01],
                  dips=[[0.06, 0.0, 0.003, 0.01], [0.1, -0.02, 0.002, 0.02]], stiffness=1e4)
    rng = np.random.default_rng(7)
    for x, y, dz in rng.uniform([-0.05, -0.1, -0.005], [0.25, 0.1, 0.005], size=(2000, 3)):
        p = np.array([x, y, f.height([x, y]) + dz])
        phi, pc, nu = f.geometry(p)
        h, hx, hy = f.height_formula(pc[0], pc[1])[:3]
        assert pc[2] == h
        np.testing.assert_allclose(nu, np.array([-hx, -hy, 1.0]) / math.sqrt(1.0 + hx * hx + hy * hy), rtol=0,
                                   atol=1e-15)
        d = p - pc
        assert abs(d[0] + hx * d[2]) < 1e-12 and abs(d[1] + hy * d[2]) < 1e-12
        np.testing.assert_allclose(d, phi * nu, rtol=0, atol=1e-13)
        assert np.sign(phi) == np.sign(dz) or abs(dz) < 1e-9


def test_bump_field_derivatives_are_the_finite_differences_of_its_height():
    """h_x, h_y are central differences of h, and h_xx, h_xy, h_yy central differences of h_x, h_y (dips included):
    an outside reference for the contact's slope and for the curvature the wipe's analysis reads."""
    f = BumpField([0.0, -0.05], 0.005, [41, 21], 0.1, 0.004, 0.15, [0.03, 0.01],
                  dips=[[0.06, 0.0, 0.003, 0.01], [0.1, -0.02, 0.002, 0.02]], stiffness=1e4)
    rng = np.random.default_rng(31)
    e = 1e-6
    for x, y in rng.uniform([-0.05, -0.1], [0.25, 0.1], size=(200, 2)):
        h, hx, hy, hxx, hxy, hyy = f.height_formula(x, y)
        assert h == f.height([x, y])
        assert hx == pytest.approx((f.height([x + e, y]) - f.height([x - e, y])) / (2 * e), abs=1e-8)
        assert hy == pytest.approx((f.height([x, y + e]) - f.height([x, y - e])) / (2 * e), abs=1e-8)
        px, mx, py, my = (f.height_formula(*u) for u in ((x + e, y), (x - e, y), (x, y + e), (x, y - e)))
        assert hxx == pytest.approx((px[1] - mx[1]) / (2 * e), rel=1e-5, abs=1e-4)
        assert hxy == pytest.approx((py[1] - my[1]) / (2 * e), rel=1e-5, abs=1e-4)
        assert hxy == pytest.approx((px[2] - mx[2]) / (2 * e), rel=1e-5, abs=1e-4)
        assert hyy == pytest.approx((py[2] - my[2]) / (2 * e), rel=1e-5, abs=1e-4)


def test_spiral_reference_is_archimedean_at_constant_speed():
    """x_d lies on r = pitch·θ/2π (θ unwrapped) and moves at the given speed along the curve (finite differences)."""
    pitch, speed = 0.005, 0.05
    ref = spiral_reference([0.0, 0.0, 0.0], pitch, 0.012, speed, 0.0, 0.1)
    t = np.linspace(0.1, 1.5, 2000)  # cruising from the end of the 0.1-s ramp (θ < π at its start: one branch)
    p = np.array([ref.at(ti).position for ti in t])
    theta = np.unwrap(np.arctan2(p[:, 1], p[:, 0]))
    np.testing.assert_allclose(np.hypot(p[:, 0], p[:, 1]), pitch * theta / (2 * math.pi), atol=2e-6)
    v = np.linalg.norm(np.diff(p, axis=0), axis=1) / np.diff(t)
    np.testing.assert_allclose(v, speed, rtol=0.01)
    np.testing.assert_allclose([ref.at(ti).velocity for ti in t[::50]], np.gradient(p, t, axis=0)[::50], atol=2e-3)


@pytest.fixture(scope="module")
def wipe():
    """panda-wipe-heightfield, run once: the case, its result and its (bare) bump field."""
    scn = load_scenario("panda-wipe-heightfield")
    run = run_scenario(scn)
    env = build_case(scn.cases[0])["environment"]
    return run.cases[0], getattr(env, "surface", env)


def test_wipe_normal_force_within_the_curvature_bound(wipe):
    """After the first contact transient, |10 N − f_n| stays below the first-order bound of analysis/surface_following.py
    at the path's largest curvature (from the height field along the simulated path) and speed, and reaches 60 % of it."""
    case, field = wipe
    res = case.result
    sel = (res.t >= 1.0) & (res.t <= 2.9)  # cruising at 5 cm/s: after the speed ramp's transient, before the stop
    fn = np.asarray(res.signals["normal_force"])[sel]
    speed = float(np.max(np.asarray(res.signals["tangential_speed"])[sel]))
    kappa = [field.path_curvature(x, y, [1.0, 0.0]) for x, y in res.x[sel][::20, :2]]
    assert min(kappa) < 0 < max(kappa)  # a crest and a trough on the path
    bound = path_following_bound(10.0, speed, kappa, 1e4, 2500.0, 100.0, 0.05, sample_time=TS).bound
    dev = float(np.max(np.abs(fn - 10.0)))
    assert dev <= 1.05 * bound, (dev, bound)
    assert dev >= 0.6 * bound, (dev, bound)
    assert bound < 1.0  # the acceptance: 10 N within 1 N
    assert all(c["ok"] for c in case.checks)


def test_wipe_analysis_is_the_bound_at_the_crest_curvature(wipe):
    """`analyze`'s numbers: the path's largest curvature is A k² (closed form), and the bound is the circle's at 1/(A k²)."""
    from forcecontrol.analysis.surface_following import surface_following_error

    case, _ = wipe
    k = 2 * math.pi / 0.2
    assert case.analysis["path_curvature_max"] == pytest.approx(0.005 * k * k, rel=1e-9)
    ref = surface_following_error(10.0, 0.05, 1 / (0.005 * k * k), 1e4, 2500.0, 100.0, 0.05, sample_time=TS)
    assert case.analysis["normal_force_bound"] == pytest.approx(ref.bound, rel=1e-12)


def test_wipe_estimate_tracks_the_true_normal(wipe):
    """The estimated normal follows the true one within the lag atan(v τ |κ|) (+10 %) while cruising."""
    case, field = wipe
    res = case.result
    sel = (res.t >= 1.0) & (res.t <= 2.9)
    err = np.abs(np.asarray(res.signals["normal_angle_error"])[sel])
    kmax = max(abs(field.path_curvature(x, y, [1.0, 0.0])) for x, y in res.x[sel][::20, :2])
    assert float(err.max()) <= 1.1 * math.atan(0.0526 * 0.05 * kmax)


@pytest.fixture(scope="module")
def search():
    """panda-spiral-search, run once (the hole inside the spiral, then outside), with the warnings it gave."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        run = run_scenario(load_scenario("panda-spiral-search"))
    return run, [str(w.message) for w in caught]


def test_spiral_search_finds_the_hole_where_it_is(search):
    """The tip drops past the threshold within the dip's detection radius w √(2 ln(d/threshold)) of its centre; it stops there."""
    run, said = search
    case = run.cases[0]
    assert case.metrics["hole_found"] == 1.0
    found = np.array([case.metrics["hole_x"], case.metrics["hole_y"]])
    centre, depth, width, threshold = np.array([0.312890586, -0.005]), 0.003, 0.004, 0.001
    radius = width * math.sqrt(2 * math.log(depth / threshold))
    assert np.linalg.norm(found - centre) <= radius
    assert any("hole found at t = " in s for s in said)
    assert case.analysis["hole_in_reach"] is True and case.analysis["hole_detection_radius"] == pytest.approx(radius, rel=1e-12)
    res = case.result
    t_found = next(e["t"] for e in res.events if e["event"] == "hole found")
    after = res.t >= t_found + 0.3
    held = res.x[after][:, :2]
    np.testing.assert_allclose(held, np.broadcast_to(found, held.shape), atol=1.5e-3)  # held there, not spiralling on


def test_spiral_search_says_not_found(search):
    """With the hole outside the spiral's radius the run logs and says 'hole not found' (silence is a defect)."""
    run, said = search
    case = run.cases[1]
    assert case.metrics["hole_found"] == 0.0
    assert case.analysis["hole_in_reach"] is False  # the analysis said so before the run
    assert [e["event"] for e in case.result.events] == ["hole not found"]
    assert any("hole not found" in s for s in said)
    doc = run.to_json()
    assert doc["cases"][1]["events"][0]["event"] == "hole not found"
    assert [w["kind"] for w in doc["cases"][1]["warnings"]] == ["hole not found"]  # a warning, not only an event
    assert not any(w["kind"] == "hole not found" for w in doc["cases"][0]["warnings"])
    assert all(c["ok"] for c in case.checks)


# ----------------------------------------------------------------------------- animation: the surface drawn


def _surfaces():
    from forcecontrol.environments import ElasticCylinder, ElasticSphere, FrictionalContact, HeightField

    hf = HeightField(0.02 * np.sin(np.linspace(0, 3, 12))[:, None] * np.ones(8), [0.0, -0.1], 0.03, 1e4)
    return {
        "sphere": ElasticSphere([0.3, 0.0, 0.29], 0.2, 1e4),
        "cylinder": ElasticCylinder([0.3, 0.0, 0.39], [0.0, 1.0, 0.0], 0.1, 1e4),
        "height field": hf,
        "bump field with friction": FrictionalContact(
            BumpField([0.2, -0.05], 0.005, [40, 21], 0.48, 0.005, 0.2, [0.3, 0.0], stiffness=1e4), 0.3, 0.2),
        "circle (planar)": ElasticSphere([1.0, 0.35], 0.2, 1e4),
    }


@pytest.mark.parametrize("name", list(_surfaces()))
def test_drawn_surface_points_lie_on_the_environment_surface(name):
    """Every point of the animation's surface patch (3-D) or curve (planar) has φ = 0 on the environment (1e-9 m)."""
    from forcecontrol.viz.surface_mesh import surface_patch

    env = _surfaces()[name]
    surface = getattr(env, "surface", env)
    tips = np.array([[0.31, 0.0, 0.5], [0.33, 0.01, 0.49]]) if surface.space == 3 else np.array([[1.0, 0.14], [1.05, 0.15]])
    pts = surface_patch(env, tips, 0.05)
    flat = pts.reshape(-1, surface.space)
    assert flat.shape[0] >= 25
    assert max(abs(surface.signed_distance(p)) for p in flat) < 1e-9
    assert float(np.ptp(flat, axis=0).max()) > 0.05  # a patch, not a point


def test_animation_draws_the_curved_surface_not_a_plane():
    """The 3-D and planar scenes draw the surface patch (one surface collection, one curve more than with no environment)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from forcecontrol.viz.animation import _Planar, _Spatial

    env3 = _surfaces()["sphere"]
    pts3 = np.array([[[0.0, 0.0, 0.3], [0.3, 0.0, 0.5]], [[0.0, 0.0, 0.3], [0.32, 0.0, 0.49]]])
    counts = []
    for env in (None, env3):
        fig = plt.figure()
        scene = _Spatial(fig, pts3, env, np.zeros((2, 3)), np.zeros(2))
        counts.append(len(scene.ax.collections))
        plt.close(fig)
    assert counts[1] == counts[0] + 1
    env2 = _surfaces()["circle (planar)"]
    pts2 = np.array([[[0.0, 0.0], [0.5, 0.5], [1.0, 0.15]], [[0.0, 0.0], [0.5, 0.5], [1.05, 0.16]]])
    lines = []
    for env in (None, env2):
        fig = plt.figure()
        scene = _Planar(fig, pts2, env, np.zeros((2, 2)), np.zeros(2))
        lines.append(scene.ax.lines)
        plt.close(fig)
    assert len(lines[1]) == len(lines[0]) + 1
    xy = np.asarray(lines[1][0].get_xydata())
    assert max(abs(env2.signed_distance(p)) for p in xy) < 1e-9


# ----------------------------------------------------------------------------- refusals


@pytest.mark.parametrize(("build", "match"), [
    (lambda: BumpField([0, 0], 0.01, [3, 10], 0.0, stiffness=1e4), "shape must be two integers >= 4"),
    (lambda: BumpField([0, 0], 0.01, [10, 10], 0.0, crest=[0, 0, 0], stiffness=1e4), r"crest must be \(x, y\)"),
    (lambda: BumpField([0, 0], 0.01, [10, 10], 0.0, dips=[[0, 0, 1e-3, 0.0]], stiffness=1e4), "dips must be rows"),
    (lambda: BumpField([0, 0], 0.01, [10, 10], 0.0, dips=[1, 2, 3], stiffness=1e4), "dips must be rows"),
    (lambda: BumpField([0, 0], 0.01, [10, 10], 0.0, wavelength=0.0, stiffness=1e4), "wavelength must be"),
    (lambda: spiral_reference([0, 0], 0.005, 0.01, 0.05), "center must have 3 components"),
    (lambda: spiral_reference([0, 0, 0], 0.0, 0.01, 0.05), "pitch, radius, speed and accel_time must be positive"),
    (lambda: spiral_reference([0, 0, 0], 1e-6, 100.0, 1e-3), r"the spiral .* takes .* s; at most 10000 s"),
    (lambda: spiral_reference([0, 0, 0], 0.005, 0.01, 0.05, orientation=[0, 0, 0], force=[1, 2]), "force must have 6"),
    (lambda: wipe_line_reference(np.zeros(3), np.ones(3), 0.05), r"start and end must be poses \(6,\)"),
    (lambda: wipe_line_reference(np.zeros(6), np.zeros(6), 0.05), "end must differ from start"),
    (lambda: wipe_line_reference(np.zeros(6), np.ones(6), 0.0), "speed and accel_time must be positive"),
    (lambda: wipe_line_reference(np.zeros(6), np.r_[100.0, 0, 0, 0, 0, 0], 1e-9), r"the line .* takes .* s; at most"),
])
def test_surface_task_parts_refuse_bad_values(build, match):
    """BumpField, the spiral and the wipe line refuse bad values with a ParameterError naming the parameter."""
    from forcecontrol.errors import ParameterError

    with pytest.raises(ParameterError, match=match):
        build()


@pytest.mark.parametrize(("table", "key", "value", "match"), [
    ("environment", "size", [0.08], r"size must be the grid's positive extent"),
    ("environment", "spacing", 1e-9, "spacing must be positive and give at most 2001 samples"),
    ("controller", "normal", [0.0, 0.0, 0.0], "normal must be a non-zero 3-vector"),
    ("controller", "threshold", 0.0, "threshold must be"),
    ("reference", "center_offset", [0.0, 0.0], "center_offset must have 3 components"),
])
def test_search_scenario_refuses_bad_keys(table, key, value, match):
    """panda-spiral-search with a bad key: a ScenarioError naming the table, the key and the value's problem."""
    from importlib.resources import files

    import tomllib

    from forcecontrol.errors import ScenarioError

    data = tomllib.loads((files("forcecontrol.scenarios") / "panda-spiral-search.toml").read_text(encoding="utf-8"))
    data.pop("case")
    data[table][key] = value
    with pytest.raises(ScenarioError, match=match):
        load_scenario(data)


def test_hole_metrics_need_the_search_controller():
    """Asking a non-search scenario for hole_found is refused, naming the metric and what it needs."""
    from forcecontrol.errors import ScenarioError
    from forcecontrol.scenarios.checks import METRICS

    parts = build_case(load_scenario("panda-wipe-heightfield").cases[0])
    with pytest.raises(ScenarioError, match="metric 'hole_found' needs the spatial-hybrid-search controller"):
        METRICS["hole_found"](None, parts, 0.1)


def test_surface_task_quantities_have_units():
    """The wipe's and the search's analysis quantities and metrics carry SI units (the flags hole_found/hole_in_reach none)."""
    from forcecontrol.scenarios.units import unit

    want = {"path_curvature_max": "1/m", "estimate_lag": "rad", "normal_force_bound": "N", "curvature_error": "N",
            "lag_error": "N", "steady_fx": "N", "steady_fz": "N", "hole_distance": "m", "hole_detection_radius": "m",
            "hole_time": "s", "hole_x": "m", "hole_y": "m", "hole_z": "m"}
    assert {k: unit(k) for k in want} == want


def test_search_ended_before_its_start_says_so():
    """A run shorter than the search's start says the search did not start (not a misleading 'no drop')."""
    from importlib.resources import files

    import tomllib

    data = tomllib.loads((files("forcecontrol.scenarios") / "panda-spiral-search.toml").read_text(encoding="utf-8"))
    data.pop("case")
    data["duration"] = 0.1
    with pytest.warns(UserWarning, match=r"hole not found: the run ended at t = 0\.1000 s, before the search's start at 0\.3 s"):
        res = run_scenario(load_scenario(data)).cases[0].result
    assert [e["event"] for e in res.events] == ["hole not found"]
