"""A cold first run (issue 33 item 5): its compile notice, once, and only the kernels the command needs.

One cold run is expensive (seconds of compiling), so a single test runs ``forcecontrol run
example-9.2`` once in a fresh process on an empty ``NUMBA_CACHE_DIR`` and once more on the cache
it filled. The command line is the console script's own ``forcecontrol.cli.main``, run by a small
driver that also records which functions Numba compiles (its ``numba:compile`` event).
No timing is asserted (``benchmarks/bench_coldstart.py`` measures it).
"""

from __future__ import annotations

import collections
import os
import subprocess
from pathlib import Path

from compile_helpers import cli_recording_compiles

NOTICE = "forcecontrol: compiling kernels"

def _run(tmp_path: Path, cache: Path, name: str) -> tuple[subprocess.CompletedProcess[str], list[str]]:
    done, compiled = cli_recording_compiles(tmp_path / f"{name}.json", ["run", "example-9.2", "--force", "--out",
                                            str(tmp_path / "out")], dict(os.environ, NUMBA_CACHE_DIR=str(cache)))
    assert done.returncode == 0, done.stderr[-3000:]
    return done, compiled


def test_cold_run_says_it_compiles_once_compiles_only_what_it_needs_and_a_warm_run_compiles_nothing(tmp_path: Path) -> None:
    """Cold: the notice once on stderr, each kernel compiled once, none the command does not use; warm: no notice, no compile."""
    cache = tmp_path / "numba-cache"
    cache.mkdir()
    cold, compiled = _run(tmp_path, cache, "cold")
    notices = [line for line in cold.stderr.splitlines() if NOTICE in line]
    assert len(notices) == 1, cold.stderr
    assert notices[0].startswith(NOTICE) and str(cache) in notices[0]
    ours = collections.Counter(n for n in compiled if n.startswith("forcecontrol."))
    assert any(".sim.loop." in n for n in ours), ours  # the cold run did compile the loop
    assert {n: k for n, k in ours.items() if k > 1} == {}, "a kernel compiled twice (two array layouts?)"
    # not used by the chapter's arm on an elastic plane: only circles, only other task sizes, or inlined twins
    unused = ("environments.surfaces.circle_wrench2", "robots.planar_2r._terms_into", "laws.inner._inverse_dynamics_general")
    assert [n for n in ours if n.endswith(unused)] == []

    warm, compiled_warm = _run(tmp_path, cache, "warm")
    assert NOTICE not in warm.stderr, warm.stderr
    assert [n for n in compiled_warm if n.startswith("forcecontrol.")] == []


def test_the_planar_twin_of_a_law_is_the_law_to_the_bit_and_refuses_other_sizes() -> None:
    """on_planar_arm(impedance) gives impedance's torques byte for byte on random states; its inner loop refuses 3 x 3."""
    import numpy as np

    import forcecontrol as fc
    from forcecontrol.laws import impedance, os_pd, workspace_size
    from forcecontrol.laws.inner import inverse_dynamics_2x2, on_planar_arm

    twin = on_planar_arm(impedance)
    assert twin is not impedance and on_planar_arm(os_pd) is os_pd  # a law without the inner loop is its own
    arm = fc.CHAPTER_ARM
    ctl = fc.ImpedanceController(arm, 100, 500, 2500)
    rng = np.random.default_rng(33)
    for _ in range(50):
        q, qd, h, ref = rng.normal(size=2), rng.normal(size=2), 50.0 * rng.normal(size=2), rng.normal(size=12)
        t = arm.terms(q, qd)
        out = []
        for law in (impedance, twin):
            u = np.empty(2)
            ok = law(0.0, 1e-3, q, qd, t.x, t.xd, t.J, t.Jdq, t.B, t.n, t.g, h, ref, ctl._params, ctl.state.copy(),
                     np.zeros(workspace_size(2, 2)), u)
            out.append((ok, u.tobytes()))
        assert out[0] == out[1]
    u3 = np.zeros(3)
    ones, zeros = np.ones(3), np.zeros(3)
    assert not inverse_dynamics_2x2(np.eye(3), ones, np.eye(3), zeros, ones, zeros, True, np.zeros(16), u3)
    assert np.isnan(u3).all()
