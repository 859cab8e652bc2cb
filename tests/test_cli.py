"""The ``shapesearch describe`` command."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from app.cli import main

FIXTURES = Path(__file__).parent / "fixtures" / "parts"


def test_describe_json_reports_cutoff_timings_and_descriptor(capsys) -> None:
    code = main(["describe", str(FIXTURES / "cylinder.stl"), "--max-points", "2000", "--json"])
    report = json.loads(capsys.readouterr().out)
    assert code == 0
    assert report["n_points"] == 2000
    assert report["cutoff"]["mode"] == "adaptive"
    assert report["cutoff"]["n"] >= report["cutoff"]["n_min"]
    assert report["cutoff"]["solver_calls"] >= 1
    assert report["timings"]["eigensolve"] > 0
    assert len(report["descriptor_head"]) == 8


def test_describe_fixed_cutoff_text(capsys) -> None:
    code = main(["describe", str(FIXTURES / "cylinder.stl"), "--max-points", "2000",
                 "--cutoff", "fixed:40"])
    out = capsys.readouterr().out
    assert code == 0
    assert "n = 40, solver calls = 1" in out


@pytest.mark.parametrize(
    ("arguments", "code", "message"),
    [
        (["--cutoff", "fixed:x"], 2, "--cutoff must be"),
        ([], 1, "empty"),
    ],
)
def test_describe_refusals_exit_nonzero_with_a_reason(tmp_path, capsys, arguments, code, message):
    empty = tmp_path / "empty.xyz"
    empty.write_bytes(b"")
    assert main(["describe", str(empty), *arguments]) == code
    assert message.lower() in capsys.readouterr().err.lower()


@pytest.mark.parametrize("command", ["serve", "worker"])
@pytest.mark.parametrize(
    ("url", "message"),
    [
        ("this is not a url", "SHAPESEARCH_DATABASE_URL is not a usable database URL"),
        ("nosuchdialect://host/db", "SHAPESEARCH_DATABASE_URL is not a usable database URL"),
        (
            "postgresql+psycopg://postgres@127.0.0.1:5432/shapesearch_no_such_database",
            "cannot open the database",
        ),
    ],
)
def test_start_up_errors_are_one_line_and_exit_code_2(command, url, message) -> None:
    """A bad database URL is the operator's mistake: one line that says what, exit code 2."""
    env = {**os.environ, "SHAPESEARCH_DATABASE_URL": url}
    done = subprocess.run(
        [sys.executable, "-m", "app.cli", command],
        env=env, capture_output=True, text=True, timeout=120,
    )
    assert done.returncode == 2
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1, done.stderr
    assert lines[0].startswith("error: ") and message in lines[0]
    if "no_such_database" in url:
        assert "shapesearch_no_such_database" in lines[0]
