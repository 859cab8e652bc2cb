"""The README's curl session, run as written against a live ``shapesearch serve``.

The ``sh`` block of the README is split into its commands (continuation lines joined); the
test prints a marker before each, runs the block with bash from the repository root with
only the port changed, and checks what every command printed.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import shutil
import subprocess
import uuid
from pathlib import Path
from typing import Any

import pytest

from tests.live_server import live_server

ROOT = Path(__file__).parents[2]
README = (ROOT / "README.md").read_text(encoding="utf-8")
MARKER = "@@step"


def session_block() -> str:
    """The first ``sh`` code block of the README."""
    match = re.search(r"^```sh\n(.*?)^```", README, flags=re.MULTILINE | re.DOTALL)
    assert match, "the README has no ```sh block"
    return match.group(1)


def commands(block: str) -> list[str]:
    """The block's commands, continuation lines joined, comment lines left out."""
    joined = block.replace("\\\n", " ")
    lines = [line.strip() for line in joined.splitlines()]
    return [line for line in lines if line and not line.startswith("#")]


def run_session(base_url: str) -> dict[str, str]:
    """{command: what it printed}, the block run as one bash script against ``base_url``."""
    steps = commands(session_block())
    script = ["set -eu"]
    for number, command in enumerate(steps):
        # curl prints no final newline: start the marker on a line of its own.
        script.append(f"echo; echo {MARKER} {number}")
        script.append(command.replace("http://127.0.0.1:8000", base_url))
    result = subprocess.run(
        ["bash", "-c", "\n".join(script)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 0, result.stderr
    parts = re.split(rf"\n{MARKER} (\d+)\n", result.stdout)
    pairs = zip(parts[1::2], parts[2::2], strict=True)
    outputs = {steps[int(n)]: text.strip() for n, text in pairs}
    assert len(outputs) == len(steps)
    return outputs


def output_of(outputs: dict[str, str], start: str) -> str:
    """What the command ``start`` printed, or the one command beginning with ``start``."""
    if start in outputs:
        return outputs[start]
    (found,) = [text for command, text in outputs.items() if command.startswith(start)]
    return found


def json_of(outputs: dict[str, str], start: str) -> Any:
    return json.loads(output_of(outputs, start))


@pytest.mark.slow
def test_readme_curl_session_runs_as_written(tmp_path: Path) -> None:
    if shutil.which("curl") is None:
        if os.environ.get("CI") == "true":
            pytest.fail("the README session needs curl, and CI=true: .ci/run installs it")
        pytest.skip("the README session needs curl")
    block = session_block()
    for path in re.findall(r"file=@(\S+)", block):
        assert (ROOT / path).is_file(), f"the README uploads {path}, which is not in the repo"

    with live_server(tmp_path) as base_url:
        outputs = run_session(base_url)

    model = json_of(outputs, "curl -s $S/v1/models/$ID")
    assert model["status"] == "ready", model
    assert model["external_id"] == "PN-1001" and model["metadata"] == {"material": "steel"}
    assert model["cutoff"]["n"] >= 2 and model["n_points"] > 100

    alone = json_of(outputs, 'curl -s "$S/v1/models/$ID/similar?k=5"')
    assert alone["query"]["model_id"] == model["id"]
    assert alone["results"] == []

    pair = json_of(outputs, 'curl -s "$S/v1/models/$ID/similar?k=5&metadata')
    assert [r["model"]["external_id"] for r in pair["results"]] == ["PN-1002"]
    assert 0 < pair["results"][0]["score"] <= 1

    search = json_of(outputs, "curl -s -F file=@tests/fixtures/scans/")
    assert search["query"]["n_points"] > 100
    ranked = [r["model"]["external_id"] for r in search["results"]]
    assert ranked == ["PN-1001", "PN-1002"], "the scan of angle_block must find it first"

    upsert = json_of(outputs, "curl -s -X PUT")
    assert upsert["id"] == pair["results"][0]["model"]["id"], "an upsert keeps the model's id"
    assert upsert["external_id"] == "PN-1002" and upsert["job"]["status"] == "queued"
    assert upsert["file"]["filename"] == "featuretype.STL", "the current file until described"

    round_stl = (ROOT / "tests/fixtures/parts/round.stl").read_bytes()
    revisions = json_of(outputs, "curl -s $S/v1/models/$ID2/revisions")["items"]
    assert [(r["number"], r["status"]) for r in revisions] == [(2, "current"), (1, "superseded")]
    assert revisions[0]["file"]["sha256"] == hashlib.sha256(round_stl).hexdigest()
    assert revisions[1]["file"]["filename"] == "featuretype.STL"

    jobs = json_of(outputs, 'curl -s "$S/v1/jobs?limit=5"')
    assert jobs["next_cursor"] is None
    assert [job["model_id"] for job in jobs["items"]] == [upsert["id"], upsert["id"], model["id"]]
    assert jobs["items"][0]["id"] == upsert["job"]["id"]
    assert {job["status"] for job in jobs["items"]} == {"done"}

    download = output_of(outputs, "curl -s -o /tmp/")
    digest, path = download.split()
    assert digest == revisions[0]["file"]["sha256"] and path == "/tmp/PN-1002.stl"

    stats = json_of(outputs, "curl -s $S/v1/stats")
    assert stats["models"] == 2 and stats["by_status"] == {"ready": 2}
    assert stats["by_descriptor_version"] == {stats["current_descriptor_version"]: 2}
    assert stats["jobs_by_status"] == {"done": 3}
    assert model["descriptor_version"] == stats["current_descriptor_version"]

    duplicates = json_of(outputs, 'curl -s "$S/v1/duplicates?min_score=0.98"')
    assert duplicates["min_score"] == 0.98 and duplicates["groups"] == []
    assert duplicates["descriptor_version"] == stats["current_descriptor_version"]
    assert duplicates["models"] == 2 and duplicates["stale"] is False

    viewer = output_of(outputs, "echo")
    assert viewer == f"{base_url}/#/models/{uuid.UUID(model['id'])}"
