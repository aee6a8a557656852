"""Sweeps survive damage: corrupt or truncated parts, a corrupt stamp or table, a second sweep on the same output.

Each resumed table is compared with an uninterrupted run of the same sweep (the reference).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from forcecontrol.sweep.run import prepare_sweep, run_sweep
from forcecontrol.sweep.spec import SweepDefinition, SweepError, SweepWarning

pytest.importorskip("pyarrow")

PARAMS = ["environment.stiffness=linspace(1000,5000,6)", "controller.damping=400,600"]


def _prep():
    return prepare_sweep("example-9.2", SweepDefinition.from_options(PARAMS))


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """An uninterrupted run of the sweep."""
    return run_sweep(_prep(), tmp_path_factory.mktemp("ref") / "t.parquet", block_size=4).table


def _parts_of_a_killed_run(tmp_path):
    """Run the sweep, then recreate its parts folder as a killed run would leave it (parts, no table)."""
    out = tmp_path / "t.parquet"
    prep = _prep()
    run_sweep(prep, out, block_size=4)
    parts = out.with_name(out.name + ".parts")
    parts.mkdir()
    (parts / "sweep.json").write_text(json.dumps(prep.metadata, default=str))
    import pyarrow.parquet as pq

    table = pq.read_table(out)
    for lo in range(0, prep.n_cases, 4):
        block = table.slice(lo, 4)
        ids = block.column("case_id").to_pylist()
        pq.write_table(block, parts / f"part-{min(ids):08d}-{max(ids):08d}-{len(ids)}.parquet")
    out.unlink()
    return out, parts, prep


def _same(a, b):
    cols = ["case_id", "case", "settled_force", "settling_time", "overshoot", "stable"]
    assert a[cols].equals(b[cols])


@pytest.mark.parametrize("damage", ["truncate", "garbage", "empty", "other-sweep-name"])
def test_damaged_part_is_moved_aside_and_rerun(tmp_path, reference, damage):
    """A truncated, garbage, empty or misnamed part: warned, moved aside, its cases re-run; the table equals the reference."""
    out, parts, prep = _parts_of_a_killed_run(tmp_path)
    victim = sorted(parts.glob("part-*.parquet"))[1]
    data = victim.read_bytes()
    if damage == "truncate":
        victim.write_bytes(data[: len(data) // 2])
    elif damage == "garbage":
        victim.write_bytes(os.urandom(len(data)))
    elif damage == "empty":
        victim.write_bytes(b"")
    else:  # a part whose name promises other cases than it holds
        victim.rename(victim.with_name("part-00000100-00000103-4.parquet"))
    with pytest.warns(SweepWarning, match="moved to .*corrupt"):
        res = run_sweep(prep, out, block_size=4)
    assert res.ran == 4 and res.resumed == prep.n_cases - 4
    _same(res.table, reference)


def test_corrupt_stamp_and_corrupt_table_are_recovered(tmp_path, reference):
    """A corrupt sweep.json (parts verified one by one) and a truncated final table (rebuilt): warned, same table."""
    out, parts, prep = _parts_of_a_killed_run(tmp_path)
    (parts / "sweep.json").write_text("{not json")
    with pytest.warns(SweepWarning, match="sweep.json is unreadable"):
        res = run_sweep(prep, out, block_size=4)
    assert res.ran == 0
    _same(res.table, reference)
    out.write_bytes(out.read_bytes()[:100])
    with pytest.warns(SweepWarning, match="t.parquet is unreadable"):
        res = run_sweep(prep, out, block_size=4)
    _same(res.table, reference)


def test_second_sweep_on_the_same_output_is_refused(tmp_path, reference):
    """A live process holding the lock: a second sweep refuses (naming the process); a dead owner's lock is taken over."""
    out = tmp_path / "t.parquet"
    lock = out.with_name(out.name + ".lock")
    sleeper = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    try:
        lock.write_text(str(sleeper.pid))
        with pytest.raises(SweepError, match=rf"another sweep \(process {sleeper.pid}\) is writing"):
            run_sweep(_prep(), out, block_size=4)
    finally:
        sleeper.kill()
        sleeper.wait()
    with pytest.warns(SweepWarning, match="stale lock"):
        res = run_sweep(_prep(), out, block_size=4)
    _same(res.table, reference)
    assert not lock.exists()


def test_sweep_reads_scenario_files_like_run(tmp_path):
    """A UTF-16 scenario given to a sweep: the same ScenarioError as `run` (the sweep reads files with the loader's reader)."""
    from forcecontrol.errors import ScenarioError
    from forcecontrol.scenarios import scenario_source
    from forcecontrol.sweep.run import load_sweep_scenario

    p = tmp_path / "utf16.toml"
    p.write_bytes(scenario_source("example-9.2").read_text(encoding="utf-8").encode("utf-16"))
    with pytest.raises(ScenarioError, match="not UTF-8 text"):
        load_sweep_scenario(p)
