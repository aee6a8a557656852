"""A command given --json that fails prints a JSON object on stdout too, not an empty stdout.

Before, `forcecontrol run nope --json | jq` (or a script's ``json.loads(stdout)``) met an empty stdout and had to
read stderr to learn why. Now the refusal is ``{"error": {"type", "message"}, "exit_code": 2}`` on stdout, the
message the one ``error:`` line on stderr gives, with exit code 2; without --json, stdout stays empty.
"""

from __future__ import annotations

import json

import pytest

from journeys_helpers import assert_no_traceback, forcecontrol

#: one refused command line per command that has --json, the error class the library raises, a part of the message
REFUSED = [
    (("run", "nope"), "ScenarioError", "unknown scenario 'nope'"),
    (("analyze", "missing.toml"), "ScenarioError", "scenario file 'missing.toml' does not exist"),
    (("run", "example-9.2", "--set", "duration=-1"), "ScenarioError", "'duration' must be a positive number"),
    (("sweep", "example-9.2", "-p", "environment.stiffness=-1"), "SweepError", "stiffness must be a non-negative number"),
    (("task", "nope"), "ParameterError", "task must be one of"),
    (("compare", "nope"), "ScenarioError", "unknown scenario 'nope'"),
    (("design", "impedance", "--k-min", "5", "--k-max", "1"), "ParameterError", "--k-min and --k-max must satisfy"),
    (("import-config", "missing.yaml"), "ParameterError", "missing.yaml: cannot be read"),
]


@pytest.mark.parametrize("args, kind, text", REFUSED, ids=[" ".join(a[:2]) for a, _, _ in REFUSED])
def test_a_refused_json_command_prints_its_error_as_json(tmp_path, args, kind, text):
    """Exit 2, no traceback; stdout is one JSON object naming the error's class and its message, equal to the
    'error:' line of stderr; the same command without --json leaves stdout empty and says the same on stderr."""
    proc = forcecontrol(tmp_path, *args, "--json", ok=False)
    assert proc.returncode == 2, (proc.stdout, proc.stderr)
    assert_no_traceback(proc)
    doc = json.loads(proc.stdout)
    assert doc["exit_code"] == 2 and doc["error"]["type"] == kind and text in doc["error"]["message"], doc
    said = [line for line in proc.stderr.splitlines() if line.startswith("error: ")]
    assert len(said) == 1 and " ".join(said[0].removeprefix("error: ").split()) in " ".join(doc["error"]["message"].split())
    plain = forcecontrol(tmp_path, *args, ok=False)
    assert plain.returncode == 2 and plain.stdout == "" and said[0] in plain.stderr


def test_a_command_that_printed_its_object_prints_no_second_one(tmp_path):
    """`run --json --check` with a missed check: the run's object, once, and exit 1 (not an error object)."""
    proc = forcecontrol(tmp_path, "run", "example-9.2", "--set", "environment.stiffness=2e4", "--json", "--check",
                        "--no-figure", ok=False)
    assert proc.returncode == 1, proc.stderr
    doc = json.loads(proc.stdout)  # one object: json.loads refuses trailing data
    assert "error" not in doc and doc["all_checks_pass"] is False
