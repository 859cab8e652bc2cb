"""The ``shapesearch describe`` command."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from importlib.metadata import version
from pathlib import Path

import pytest

from app.cli import main

FIXTURES = Path(__file__).parents[1] / "fixtures" / "parts"


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


@pytest.mark.slow
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


@pytest.mark.slow
@pytest.mark.parametrize(
    ("variables", "named"),
    [
        ({"SHAPESEARCH_CUTOFF_N_MIN": "600"},
         ["SHAPESEARCH_CUTOFF_N_MIN", "SHAPESEARCH_CUTOFF_N_MAX"]),
        ({"SHAPESEARCH_MAX_POINTS": "50"}, ["SHAPESEARCH_MAX_POINTS", "SHAPESEARCH_MIN_POINTS"]),
        ({"SHAPESEARCH_CUTOFF_XI": "2"}, ["SHAPESEARCH_CUTOFF_XI"]),
        ({"SHAPESEARCH_DESCRIPTOR_T_MIN": "0"}, ["SHAPESEARCH_DESCRIPTOR_T_MIN"]),
        # The shipped vocabulary was fitted on 16 times: 8 cannot use it.
        ({"SHAPESEARCH_DESCRIPTOR_TIMES": "8"},
         ["SHAPESEARCH_DESCRIPTOR_TIMES", "descriptor.local_vocabulary"]),
    ],
)
def test_settings_that_do_not_work_together_are_named_at_start_up(
    tmp_path: Path, variables: dict[str, str], named: list[str]
) -> None:
    """The engine's cross-field rules are checked before anything starts, and the line names
    the variables involved (each valid alone, as pydantic checks them)."""
    env = {**os.environ, "SHAPESEARCH_DATA_DIR": str(tmp_path), **variables}
    env.pop("SHAPESEARCH_DATABASE_URL", None)
    done = subprocess.run(
        [sys.executable, "-m", "app.cli", "serve"],
        env=env, capture_output=True, text=True, timeout=120,
    )
    assert done.returncode == 2
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: invalid setting: "), done.stderr
    for name in named:
        assert name in lines[0]


def test_version_and_an_import_without_a_url(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    with pytest.raises(SystemExit) as done:
        main(["--version"])
    assert done.value.code == 0
    assert capsys.readouterr().out.strip() == f"shapesearch {version('shapesearch')}"
    monkeypatch.delenv("SHAPESEARCH_URL", raising=False)
    assert main(["import", str(tmp_path)]) == 2
    assert "SHAPESEARCH_URL" in capsys.readouterr().err
