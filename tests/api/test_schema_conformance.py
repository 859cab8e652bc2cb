"""The OpenAPI document matches behaviour: schemathesis generates about 1,300 requests
from it (examples, coverage, fuzzing and stateful phases) against a real server on a fresh
database and runs every check (``--checks all``): status documented, problem+json and
headers as declared, no server error, schema-invalid requests refused, schema-valid
requests accepted. What JSON Schema cannot state (a file's content, a webhook host's
addresses, a metadata object's nested limits) is documented per operation and held to
exactly those refusals by tests/schemathesis_hooks.py. Settings: tests/schemathesis.toml.
About 20-35 s on two cores."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from tests.conftest import SMALL_ENGINE
from tests.servers import running_server

pytest.importorskip("schemathesis")

CONFIG = Path(__file__).parents[1] / "schemathesis.toml"
HOOKS = Path(__file__).parents[1] / "schemathesis_hooks.py"
EXAMPLES_PER_OPERATION = 10  # about 1,300 cases over the 25 operations


@pytest.mark.slow
def test_the_api_conforms_to_its_openapi_document(tmp_path: Path) -> None:
    cli = shutil.which("schemathesis", path=str(Path(sys.executable).parent))
    assert cli is not None, "schemathesis is in the test extra"
    with running_server(tmp_path, **SMALL_ENGINE, workers=0) as (base, _):
        run = subprocess.run(
            [
                cli, "--config-file", str(CONFIG), "run", f"{base}/openapi.json",
                # Naming the hooks' check fails the run unless the hooks loaded.
                "--checks", "all,only_unstated_limits_refuse",
                "--max-examples", str(EXAMPLES_PER_OPERATION),
                "--seed", "1", "--workers", "1", "--request-timeout", "120",
                "--phases", "examples,coverage,fuzzing,stateful",
            ],
            capture_output=True, text=True, timeout=300,
            env={**os.environ, "SCHEMATHESIS_HOOKS": str(HOOKS)},
        )
    assert run.returncode == 0, run.stdout[-8000:] + run.stderr[-2000:]
    assert "Stateful" in run.stdout


@pytest.mark.slow
def test_405_names_every_method_and_the_document_says_what_schemathesis_found(
    database_url: str,
) -> None:
    from fastapi.testclient import TestClient

    from app.api.main import create_app
    from tests.conftest import make_settings

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


def test_the_hooks_allow_only_what_the_document_cannot_state() -> None:
    """tests/schemathesis_hooks.py lets a schema-valid request be refused for a file's
    content, a webhook host or nested metadata, and for nothing the schema states."""
    from app.api.main import create_app
    from tests.conftest import make_settings
    from tests.schemathesis_hooks import UNSTATED_LIMITS

    document = create_app(make_settings("sqlite://")).openapi()
    operations = {f"{m.upper()} {p}" for p, ops in document["paths"].items() for m in ops}
    assert set(UNSTATED_LIMITS) <= operations
    prefix = "urn:shapesearch:problem:"
    upload = UNSTATED_LIMITS["POST /v1/models"]
    assert upload({"type": prefix + "unparsable", "pointer": ""})
    assert upload({"type": prefix + "validation-error", "pointer": "/metadata/a\x00"})
    assert not upload({"type": prefix + "validation-error", "pointer": "/name"})
    assert not upload({"type": prefix + "validation-error", "pointer": "/metadata",
                       "detail": "/metadata: must be a JSON object"})
    assert not upload({"type": prefix + "webhook-url-refused"})
    assert UNSTATED_LIMITS["POST /v1/webhooks"]({"type": prefix + "webhook-url-refused"})
    assert not UNSTATED_LIMITS["POST /v1/search"](
        {"type": prefix + "validation-error", "pointer": "/metadata/a"}
    )
