"""Sweep parts carry a checksum of their rows and the sweep id: a silently flipped bit is caught on resume (issue 28)."""

from __future__ import annotations

import struct

import pytest

from forcecontrol.sweep import SweepDefinition, prepare_sweep, run_sweep
from forcecontrol.sweep.spec import SweepWarning

pq = pytest.importorskip("pyarrow.parquet")

PARAMS = {"environment.stiffness": [1000.0, 2000.0, 3000.0, 4000.0]}


def _prep():
    return prepare_sweep("example-9.2", SweepDefinition.from_options(PARAMS))


def _stop_at_the_end(done: int, total: int) -> None:
    if done == total:  # every part stored, the table not yet assembled
        raise KeyboardInterrupt


def test_flipped_bit_in_a_part_is_detected_recomputed_and_the_table_equals_the_uninterrupted_one(tmp_path):
    """One mantissa bit flipped in a settled_force value of a readable part: warned, set aside, rerun; same table."""
    whole = run_sweep(_prep(), tmp_path / "whole.parquet", workers=1, block_size=2).table
    out = tmp_path / "cut.parquet"
    with pytest.raises(KeyboardInterrupt):
        run_sweep(_prep(), out, workers=1, block_size=2, progress=_stop_at_the_end)
    parts = sorted((tmp_path / "cut.parquet.parts").glob("part-*.parquet"))
    victim = parts[1]
    table = pq.read_table(victim)
    # plain, uncompressed bytes without statistics (so a value's 8 bytes are in its data page only); metadata kept
    pq.write_table(table, victim, compression="none", use_dictionary=False, write_statistics=False)
    value = table.column("settled_force").to_pylist()[0]
    raw = victim.read_bytes()
    packed = struct.pack("<d", value)
    at = raw.index(packed) + 5
    victim.write_bytes(raw[:at] + bytes([raw[at] ^ 0x10]) + raw[at + 1:])  # one mantissa bit
    damaged = pq.read_table(victim)
    assert not damaged.equals(table) and damaged.num_rows == table.num_rows  # readable, silently wrong
    with pytest.warns(SweepWarning, match="checksum fails"):
        res = run_sweep(_prep(), out, workers=1, block_size=2)
    assert (res.ran, res.resumed) == (2, res.table.shape[0] - 2)
    assert res.table.equals(whole)


def test_part_of_another_sweep_with_its_own_valid_checksum_is_refused(tmp_path):
    """A part whose rows and checksum are consistent but made for another sweep id fails (the id is in the checksum)."""
    from forcecontrol.sweep.store import META_KEY, checksum_fault, with_checksum

    res = run_sweep(_prep(), tmp_path / "t.parquet", workers=1, block_size=8)
    table = pq.read_table(tmp_path / "t.parquet")
    assert checksum_fault(table, res.metadata["sweep_id"]) is None
    other = with_checksum(table, "another-sweep")
    assert "checksum fails" in checksum_fault(other, res.metadata["sweep_id"])
    assert META_KEY in other.schema.metadata


def test_sweep_json_note_reports_the_set_aside_part(tmp_path):
    """`forcecontrol sweep --json` after a part's checksum fails lists the set-aside part in its notes."""
    import json

    from typer.testing import CliRunner

    from forcecontrol.cli import app

    out = tmp_path / "s.parquet"
    cli_prep = prepare_sweep("example-9.2", SweepDefinition.from_options(["environment.stiffness=1000,2000,3000,4000"]))
    with pytest.raises(KeyboardInterrupt):
        run_sweep(cli_prep, out, workers=1, block_size=2, progress=_stop_at_the_end)
    victim = sorted((tmp_path / "s.parquet.parts").glob("part-*.parquet"))[0]
    table = pq.read_table(victim)
    meta = dict(table.schema.metadata)
    changed = table.set_column(table.schema.get_field_index("settled_force"), "settled_force",
                               [[v + 1.3 for v in table.column("settled_force").to_pylist()]])
    pq.write_table(changed.replace_schema_metadata(meta), victim)  # the old checksum, new values
    res = CliRunner().invoke(app, ["sweep", "example-9.2", "--param", "environment.stiffness=1000,2000,3000,4000",
                                   "--no-figure", "--block-size", "2", "--workers", "1", "--out", str(out), "--json"])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    assert doc["ran"] == 2 and any("checksum fails" in n and victim.name in n for n in doc["notes"])


def test_sweep_json_carries_a_checksum_of_its_content(tmp_path):
    """The parts folder's sweep.json holds a SHA-256 of its other keys (recomputed here with hashlib)."""
    import hashlib
    import json

    out = tmp_path / "s.parquet"
    with pytest.raises(KeyboardInterrupt):
        run_sweep(_prep(), out, workers=1, block_size=2, progress=_stop_at_the_end)
    doc = json.loads((tmp_path / "s.parquet.parts" / "sweep.json").read_text())
    body = json.dumps({k: v for k, v in doc.items() if k != "sha256"}, sort_keys=True, separators=(",", ":"))
    assert doc["sha256"] == hashlib.sha256(f"forcecontrol sweep.json\n{body}".encode()).hexdigest()
    assert doc["sweep_id"] == _prep().sweep_id


def test_tampered_sweep_json_is_set_aside_rewritten_and_the_parts_verified(tmp_path):
    """A sweep.json edited after it was written (valid JSON, another sweep id) is warned, set aside, rewritten; same table."""
    import json

    whole = run_sweep(_prep(), tmp_path / "whole.parquet", workers=1, block_size=2).table
    out = tmp_path / "cut.parquet"
    with pytest.raises(KeyboardInterrupt):
        run_sweep(_prep(), out, workers=1, block_size=2, progress=_stop_at_the_end)
    stamp = tmp_path / "cut.parquet.parts" / "sweep.json"
    doc = json.loads(stamp.read_text())
    doc["sweep_id"] = "0" * 16  # a flipped id: it would claim the parts belong to another sweep
    stamp.write_text(json.dumps(doc))
    with pytest.warns(SweepWarning, match=r"sweep.json is damaged \(its checksum fails.*rewritten"):
        res = run_sweep(_prep(), out, workers=1, block_size=2)
    assert (res.ran, res.resumed) == (0, res.table.shape[0])  # every part verified against this sweep: none rerun
    assert res.table.equals(whole)
