"""The OpenAPI document matches behaviour: schemathesis generates a few hundred requests
from it (coverage, fuzzing and stateful phases) against a real server on a fresh database
and checks every response: status documented, problem+json and headers as declared, no
server error, schema-invalid requests refused. Settings: tests/schemathesis.toml."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import SMALL_ENGINE
from servers import running_server

pytest.importorskip("schemathesis")

CONFIG = Path(__file__).parent / "schemathesis.toml"
EXAMPLES_PER_OPERATION = 10  # about 380 cases over the 11 operations


def test_the_api_conforms_to_its_openapi_document(tmp_path: Path) -> None:
    cli = shutil.which("schemathesis", path=str(Path(sys.executable).parent))
    assert cli is not None, "schemathesis is in the test extra"
    with running_server(tmp_path, **SMALL_ENGINE, workers=0) as (base, _):
        run = subprocess.run(
            [
                cli, "--config-file", str(CONFIG), "run", f"{base}/openapi.json",
                "--checks", "all", "--max-examples", str(EXAMPLES_PER_OPERATION),
                "--seed", "1", "--workers", "1", "--request-timeout", "120",
                "--phases", "examples,coverage,fuzzing,stateful",
            ],
            capture_output=True, text=True, timeout=600,
        )
    assert run.returncode == 0, run.stdout[-8000:]
    assert "Stateful" in run.stdout


def test_405_names_every_method_and_the_document_says_what_schemathesis_found(
    database_url: str,
) -> None:
    from conftest import make_settings
    from fastapi.testclient import TestClient

    from app.api.main import create_app

    with TestClient(create_app(make_settings(database_url))) as client:
        put = client.put("/v1/models/abc")
        document = client.get("/openapi.json").json()
        malformed = client.post(
            "/v1/models", content=b"garbage",
            headers={"content-type": "multipart/form-data; boundary=xx"},
        )
    assert put.status_code == 405
    assert put.headers["allow"] == "DELETE, GET, HEAD, PATCH"
    create = document["paths"]["/v1/models"]["post"]
    assert {} in create["security"]  # the key is optional: an open service needs none
    assert malformed.status_code == 400 and "400" in create["responses"]
    assert "get_model" in create["responses"]["202"]["links"]
