"""Kind (b): recorded data: sampled-reference CSVs, trace CSVs, Parquet, ROS 2 bags and MCAP files, then corrupted.

Valid files are written first (CSV by hand, bags and MCAP with the rosbags and mcap libraries via
``tests/rosfiles_helpers.py``), then one corruption is applied: truncation, bit flips, wrong or
duplicated columns, NaN rows, backwards or repeated time, absurd values, an empty file, garbage,
a corrupt message in the bag's database, a broken ``metadata.yaml``. The reader is called in process.
"""

from __future__ import annotations

import random
import sqlite3
from pathlib import Path

import numpy as np

from .core import Case

FORMATS = ("reference", "trace", "parquet", "bag", "mcap")
FORMAT_WEIGHTS = (30, 30, 10, 15, 15)
TEXT_SUBS = ("truncate", "bitflip", "wrong_columns", "duplicate_column", "nan_row", "inf_value", "backwards_time",
             "repeat_time", "empty", "header_only", "garbage", "absurd", "int401", "ragged", "blank_lines")
BINARY_SUBS = ("truncate", "bitflip", "nan_values", "backwards_time", "garbage", "empty")
BAG_SUBS = ("truncate_db", "bitflip_db", "corrupt_message", "metadata_garbage", "metadata_missing", "nan_values",
            "backwards_time")  # backwards_time: messages are written in log-time order, so time still advances
#: mutations after which a successful read without a warning is a silent acceptance
INVALID = {"nan_row", "inf_value", "backwards_time", "repeat_time", "empty", "header_only", "garbage", "absurd",
           "int401", "ragged", "duplicate_column", "nan_values", "metadata_garbage", "metadata_missing",
           "corrupt_message"}


def _reference_rows(n: int) -> tuple[list[str], np.ndarray]:
    t = 0.01 * np.arange(n)
    return ["t", "x", "y", "fx", "fy"], np.column_stack([t, 1.0 + 0.1 * t, 0.1 * t, 10 * t, 0 * t])


def _trace_rows(n: int) -> tuple[list[str], np.ndarray]:
    t = 0.01 * np.arange(n)
    return ["t", "q1", "q2", "qd1", "qd2", "fx", "fy"], np.column_stack(
        [t, np.sin(t), np.cos(t), np.cos(t), -np.sin(t), 10 * t, 0 * t])


def _csv(cols: list[str], rows: np.ndarray) -> str:
    return ",".join(cols) + "\n" + "".join(",".join(f"{v:.9g}" for v in r) + "\n" for r in rows)


def _mutate_text(rng: random.Random, sub: str, cols: list[str], rows: np.ndarray) -> bytes:
    n = len(rows)
    k = rng.randrange(1, n)
    rows = rows.copy()
    cols = list(cols)
    if sub == "wrong_columns":
        cols[rng.randrange(len(cols))] = rng.choice(("T", "time", "q", "x ", "", "é", "1"))
    elif sub == "duplicate_column":
        cols[rng.randrange(2, len(cols))] = cols[1]
    elif sub == "nan_row":
        rows[k, rng.randrange(len(cols))] = np.nan
    elif sub == "inf_value":
        rows[k, rng.randrange(len(cols))] = rng.choice((np.inf, -np.inf))
    elif sub == "backwards_time":
        rows[k, 0] = rows[k - 1, 0] - rng.choice((0.001, 1.0, 1e6))
    elif sub == "repeat_time":
        rows[k, 0] = rows[k - 1, 0]
    elif sub == "absurd":
        rows[k, rng.randrange(len(cols))] = rng.choice((1e300, -1e308))
    text = _csv(cols, rows)
    raw = text.encode()
    if sub == "truncate":
        return raw[: rng.randrange(len(raw))]
    if sub == "bitflip":
        b = bytearray(raw)
        for _ in range(rng.randrange(1, 6)):
            b[rng.randrange(len(b))] ^= 1 << rng.randrange(8)
        return bytes(b)
    if sub == "empty":
        return b""
    if sub == "header_only":
        return (",".join(cols) + "\n").encode()
    if sub == "garbage":
        return bytes(rng.getrandbits(8) for _ in range(rng.randrange(1, 2000)))
    if sub == "int401":
        lines = text.splitlines()
        parts = lines[k + 1].split(",")
        parts[rng.randrange(len(parts))] = "9" * 401
        lines[k + 1] = ",".join(parts)
        return ("\n".join(lines) + "\n").encode()
    if sub == "ragged":  # one row with a field more or fewer than the header
        lines = text.splitlines()
        lines[k + 1] = lines[k + 1] + rng.choice((",1", ",1,2")) if rng.random() < 0.5 else lines[k + 1].rsplit(",", 1)[0]
        return ("\n".join(lines) + "\n").encode()
    if sub == "blank_lines":
        return text.replace("\n", "\n\n  \n", 3).encode()
    return raw


def _read(path: str, fmt: str):
    def read(d: Path):
        if fmt == "reference":
            from forcecontrol.trajectories.sampled import SampledReference

            SampledReference.from_file(d / path)
        else:
            from forcecontrol.realarm.io import read_recording

            read_recording(d / path)
        return None

    return read


def _prepare_parquet(rng_seed: str, sub: str):
    def prepare(d: Path):
        import pandas as pd

        rng = random.Random(rng_seed)
        cols, rows = _trace_rows(rng.randrange(3, 60))
        if sub == "nan_values":
            rows[rng.randrange(1, len(rows)), rng.randrange(1, len(cols))] = np.nan
        if sub == "backwards_time":
            rows[-1, 0] = rows[0, 0] - 1.0
        p = d / "run.parquet"
        pd.DataFrame(rows, columns=cols).to_parquet(p)
        raw = bytearray(p.read_bytes())
        if sub == "truncate":
            raw = raw[: rng.randrange(len(raw))]
        elif sub == "bitflip":
            for _ in range(rng.randrange(1, 6)):
                raw[rng.randrange(len(raw))] ^= 1 << rng.randrange(8)
        elif sub == "garbage":
            raw = bytearray(rng.getrandbits(8) for _ in range(rng.randrange(1, 2000)))
        elif sub == "empty":
            raw = bytearray()
        p.write_bytes(bytes(raw))

    return prepare


def _prepare_ros(rng_seed: str, fmt: str, sub: str):
    def prepare(d: Path):
        from rosfiles_helpers import write_bag, write_mcap

        rng = random.Random(rng_seed)
        n = rng.randrange(3, 30)
        t = 100.0 + 0.01 * np.arange(n)
        q = np.column_stack([np.sin(t), np.cos(t)])
        qd = -q
        w = np.column_stack([10 * np.ones(n), np.zeros(n)])
        if sub == "nan_values":
            q[rng.randrange(n), rng.randrange(2)] = np.nan
        if sub == "backwards_time":
            t[rng.randrange(1, n)] -= 5.0
        kw = {"t_w": t, "wrench": w}
        if fmt == "bag":
            p = write_bag(d / "run_bag", t, q, qd, **kw)
            db = next(p.glob("*.db3"))
            if sub == "truncate_db":
                raw = db.read_bytes()
                db.write_bytes(raw[: rng.randrange(len(raw))])
            elif sub == "bitflip_db":
                raw = bytearray(db.read_bytes())
                for _ in range(rng.randrange(1, 10)):
                    raw[rng.randrange(len(raw))] ^= 1 << rng.randrange(8)
                db.write_bytes(bytes(raw))
            elif sub == "corrupt_message":
                con = sqlite3.connect(db)
                ids = [r[0] for r in con.execute("SELECT id FROM messages ORDER BY timestamp")]
                cut = rng.choice((0, 3, 7, 11))
                con.execute("UPDATE messages SET data = substr(data, 1, ?) WHERE id = ?", (cut, rng.choice(ids)))
                con.commit()
                con.close()
            elif sub == "metadata_garbage":
                (p / "metadata.yaml").write_bytes(rng.choice((b"{{{", b"rosbag2_bagfile_information: 7\n", b"\x00\xff",
                                                              b"a: [" * 1000)))
            elif sub == "metadata_missing":
                (p / "metadata.yaml").unlink()
        else:
            p = write_mcap(d / "run.mcap", t, q, qd, **kw)
            raw = bytearray(p.read_bytes())
            if sub in ("truncate_db", "metadata_missing"):
                raw = raw[: rng.randrange(len(raw))]
            elif sub in ("bitflip_db", "corrupt_message", "metadata_garbage"):
                # flips in the data region (past the magic and header): messages, chunks, summary
                for _ in range(rng.randrange(1, 10)):
                    raw[rng.randrange(8, len(raw))] ^= 1 << rng.randrange(8)
            p.write_bytes(bytes(raw))

    return prepare


def make_cases(seed: int, count: int, sentinel: Path) -> list[Case]:
    rng = random.Random(f"data-{seed}")
    out = []
    for i in range(count):
        fmt = rng.choices(FORMATS, FORMAT_WEIGHTS)[0]
        s = f"data-{seed}-{i}"
        if fmt in ("reference", "trace"):
            sub = rng.choice(TEXT_SUBS)
            cols, rows = (_reference_rows if fmt == "reference" else _trace_rows)(rng.randrange(3, 60))
            raw = _mutate_text(rng, sub, cols, rows)
            name = "ref.csv" if fmt == "reference" else "trace.csv"

            def prepare(d: Path, raw=raw, name=name):
                (d / name).write_bytes(raw)

            invalid = sub in INVALID and not (sub == "duplicate_column" and fmt == "trace")
            out.append(Case("data", f"{fmt}:{sub}", i, f"{fmt} {name} ({sub})", prepare=prepare,
                            action=_read(name, fmt), invalid=invalid))
        elif fmt == "parquet":
            sub = rng.choice(BINARY_SUBS)
            out.append(Case("data", f"parquet:{sub}", i, f"parquet run.parquet ({sub})", prepare=_prepare_parquet(s, sub),
                            action=_read("run.parquet", fmt), invalid=sub in INVALID))
        else:
            sub = rng.choice(BAG_SUBS)
            name = "run_bag" if fmt == "bag" else "run.mcap"
            invalid = (sub in INVALID and sub != "backwards_time" and fmt == "bag") or (fmt == "mcap" and sub == "nan_values")
            out.append(Case("data", f"{fmt}:{sub}", i, f"{fmt} {name} ({sub})", prepare=_prepare_ros(s, fmt, sub),
                            action=_read(name, fmt), invalid=invalid))
    return out
