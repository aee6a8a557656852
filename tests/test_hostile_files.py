"""Hostile input files (issue 28 item 4): empty, truncated, corrupt, special, oversized, non-physical.

Each bad file is written by the test itself. Every case checks the library's error type, that the
message names the file and the problem, and that no file content leaks into the message (each
file carries a secret marker). Special files that could block or read forever (FIFO,
``/dev/zero``) are read in a subprocess with a timeout.
"""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest

from forcecontrol.errors import ForceControlError, ParameterError

SECRET = "SECRETmarker7f3a"


def _refuse(call, path, exc, *needles):
    """call() raises exc; the message names the file and each needle, and holds no secret."""
    with pytest.raises(exc) as info:
        call()
    msg = str(info.value)
    assert isinstance(info.value, ForceControlError)
    assert os.path.basename(str(path)) in msg, msg
    for n in needles:
        assert n in msg, msg
    assert SECRET not in msg, msg
    return msg


# ----------------------------------------------------------------------------- sampled references


REFERENCE_CASES = [
    ("empty.csv", "", "the file is empty"),
    ("blank.csv", "\n\n  \n", "the file is empty"),
    ("header_only.csv", f"t,x,{SECRET}\n", "at least 2 samples"),
    ("text.csv", f"t,x\n0,1\n1,{SECRET}\n", "line 3, column 'x' is not a number"),
    ("ragged.csv", f"t,x\n0,1\n1,2,{SECRET}\n", "line 3 has 3 fields, the header 2"),
    ("nan.csv", f"t,x,note_{SECRET}\n0,1,0\n\n1,nan,0\n", "column 'x' is NaN or inf at line 4"),
    ("repeat.csv", f"t,x,note_{SECRET}\n0,1,0\n0,2,0\n", "time repeats at line 3"),
    ("backwards.csv", f"t,x,note_{SECRET}\n0,1,0\n2,2,0\n1,3,0\n", "time goes backwards at line 4"),
    ("duplicate.csv", f"t,x,x\n0,1,{SECRET}\n", "column 'x' appears more than once"),
    ("environ.csv", f"PATH=/usr/bin\0{SECRET}=hunter2\0HOME=/root\0", "it has 0 data row(s)"),
    ("binary.csv", b"\xff\xfe\x00" + SECRET.encode(), "not UTF-8 text (byte 0"),
]


@pytest.mark.parametrize("name, content, problem", REFERENCE_CASES, ids=[c[0] for c in REFERENCE_CASES])
def test_a_bad_reference_file_is_refused_by_name_and_problem(tmp_path, name, content, problem):
    """Empty, text, ragged, NaN, repeated/backwards time, duplicate columns, an environ dump: ParameterError, no content."""
    from forcecontrol.trajectories.sampled import SampledReference

    p = tmp_path / name
    p.write_bytes(content if isinstance(content, bytes) else content.encode())
    exc = ParameterError
    _refuse(lambda: SampledReference.from_file(p), p, exc, problem)


def test_a_folder_named_like_a_reference_is_refused(tmp_path):
    """A folder x.csv is refused as a folder (was a TypeError)."""
    from forcecontrol.trajectories.sampled import SampledReference

    p = tmp_path / "x.csv"
    p.mkdir()
    _refuse(lambda: SampledReference.from_file(p), p, ParameterError, "it is a folder")


def test_a_reference_above_the_size_limit_is_refused_before_reading(tmp_path):
    """A file larger than max_bytes is refused with its size and the limit."""
    from forcecontrol.trajectories.sampled import SampledReference

    p = tmp_path / "big.csv"
    p.write_text("t,x\n" + "".join(f"{i},{i}\n" for i in range(200)))
    _refuse(lambda: SampledReference.from_file(p, max_bytes=100), p, ParameterError, "above the limit of 100 bytes")
    assert SampledReference.from_file(p).times.shape == (200,)


_SUBPROCESS = """
import sys
from forcecontrol.trajectories.sampled import SampledReference
try:
    SampledReference.from_file(sys.argv[1])
except Exception as exc:
    print(type(exc).__name__, exc)
"""


def _in_subprocess(path: str) -> str:
    out = subprocess.run([sys.executable, "-c", _SUBPROCESS, path], capture_output=True, text=True, timeout=120)
    return out.stdout.strip()


def test_a_fifo_reference_is_refused_without_blocking(tmp_path):
    """A FIFO as a reference is refused at once (it blocked forever): the subprocess ends within its timeout."""
    p = tmp_path / "pipe.csv"
    os.mkfifo(p)
    line = _in_subprocess(str(p))
    assert line.startswith("ParameterError") and "pipe.csv" in line and "FIFO" in line, line


@pytest.mark.parametrize("device", ["/dev/zero", "/dev/null"])
def test_a_device_reference_is_refused_without_reading(device):
    """/dev/zero (read until memory ran out) and /dev/null (IndexError) are refused as devices."""
    line = _in_subprocess(device)
    assert line.startswith("ParameterError") and device in line and "a device" in line, line


def test_a_good_reference_file_still_reads(tmp_path):
    """The strict reader keeps accepting a plain file (values from the file itself)."""
    from forcecontrol.trajectories.sampled import SampledReference

    p = tmp_path / "ok.csv"
    p.write_text("t, x, y\n0, 0, 1\n\n0.5, 1, 2\n1, 2, 3\n")
    ref = SampledReference.from_file(p, interpolation="linear")
    np.testing.assert_array_equal(ref.position_samples, [[0, 1], [1, 2], [2, 3]])
