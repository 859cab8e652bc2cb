"""The ``shapesearch describe`` command."""

from __future__ import annotations

import json
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
