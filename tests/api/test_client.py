"""The generated Python client (clients/python): in step with the OpenAPI snapshot, and
driving a live ``shapesearch serve`` with an API key, the README's client block first (run
as written), then filters, pages, a search by scan and a problem.

The client is used from the repository (``clients/python`` on ``sys.path``), as the README's
test command installs only the service; ``pip install ./clients/python`` installs the same
package. Regenerating it takes about a second (openapi-python-client, no formatter).
"""

from __future__ import annotations

import importlib.util
import os
import re
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest

from tests.live_server import live_server

ROOT = Path(__file__).parents[2]
CLIENT = ROOT / "clients" / "python"
README = (ROOT / "README.md").read_text(encoding="utf-8")
PARTS = ROOT / "tests" / "fixtures" / "parts"
SCAN = ROOT / "tests" / "fixtures" / "scans" / "angle_block_scan.ply"

sys.path.insert(0, str(CLIENT))

from shapesearch_client import AuthenticatedClient  # noqa: E402
from shapesearch_client.api.jobs import list_jobs  # noqa: E402
from shapesearch_client.api.models import (  # noqa: E402
    get_model,
    list_models,
    similar_models,
    upload_model,
)
from shapesearch_client.api.search import search_by_upload  # noqa: E402
from shapesearch_client.models import (  # noqa: E402
    BodySearchByUpload,
    BodyUploadModel,
    BodyUploadModelMetadata,
    BodyUploadModelUnits,
    MetadataFilter,
    MetadataRanges,
    ModelResource,
    Problem,
    SearchResponse,
    SimilarResponse,
)
from shapesearch_client.types import File  # noqa: E402


def regenerate_module() -> ModuleType:
    spec = importlib.util.spec_from_file_location("regenerate", CLIENT / "regenerate.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def tree(root: Path) -> dict[str, bytes]:
    return {
        path.relative_to(root).as_posix(): path.read_bytes()
        for path in sorted(root.rglob("*"))
        if path.is_file() and "__pycache__" not in path.parts
    }


@pytest.mark.slow
def test_the_client_is_in_step_with_the_snapshot(tmp_path: Path) -> None:
    pytest.importorskip("openapi_python_client")  # the test extra has it
    regenerate_module().generate(tmp_path / "shapesearch_client")
    fresh, committed = tree(tmp_path / "shapesearch_client"), tree(CLIENT / "shapesearch_client")
    changed = sorted(name for name in fresh.keys() | committed.keys()
                     if fresh.get(name) != committed.get(name))
    assert changed == [], (
        "clients/python is not generated from tests/snapshots/openapi.json: run "
        f"python clients/python/regenerate.py and commit it. Differs: {changed[:10]}"
    )
    assert len(fresh) > 50 and "api/models/similar_models.py" in fresh


def readme_client_block() -> str:
    """The ```python block of the README's "Python client" section."""
    section = README.split("## Python client", 1)[1].split("\n## ", 1)[0]
    match = re.search(r"^```python\n(.*?)^```", section, flags=re.MULTILINE | re.DOTALL)
    assert match, "the README's Python client section has no ```python block"
    return match.group(1)


@pytest.fixture(scope="module")
def service(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[str, str]]:
    """(base URL, API key) of a live server whose only key belongs to tenant acme."""
    data = tmp_path_factory.mktemp("client")
    env = {k: v for k, v in os.environ.items() if not k.startswith("SHAPESEARCH_")}
    created = subprocess.run(
        [sys.executable, "-m", "app.cli", "keys", "create", "--tenant", "acme"],
        env={**env, "SHAPESEARCH_DATA_DIR": str(data)}, capture_output=True, text=True,
        check=True, timeout=120,
    )
    with live_server(data) as url:
        yield url, created.stdout.strip()


def ready(client: AuthenticatedClient, model: Any) -> ModelResource:
    """The model once its latest job is done (a new revision's too: the model stays ready
    on its previous descriptor meanwhile)."""
    assert isinstance(model, ModelResource), model
    deadline = time.monotonic() + 120
    while model.job.status in ("queued", "running"):
        assert time.monotonic() < deadline, "not described in time"
        time.sleep(0.2)
        model = get_model.sync(str(model.id), client=client)
        assert isinstance(model, ModelResource), model
    assert model.status == "ready" and model.job.status == "done", model.error
    return model


def external_ids(answer: Any) -> list[str]:
    assert isinstance(answer, SimilarResponse | SearchResponse), answer
    return [result.model.external_id for result in answer.results]


@pytest.mark.slow
def test_the_client_drives_a_live_server(
    service: tuple[str, str], monkeypatch: pytest.MonkeyPatch
) -> None:
    url, key = service
    monkeypatch.setenv("SHAPESEARCH_URL", url)
    monkeypatch.setenv("SHAPESEARCH_API_KEY", key)
    monkeypatch.chdir(ROOT)
    readme: dict[str, Any] = {}
    exec(compile(readme_client_block(), "README.md", "exec"), readme)  # as written

    first, second, similar, revised = (readme[n] for n in ("first", "second", "similar",
                                                           "revised"))
    assert (first.status, first.external_id) == ("ready", "PN-1001")
    assert first.metadata.to_dict() == {"material": "steel"}
    assert external_ids(similar) == ["PN-1002"] and 0 < similar.results[0].score <= 1
    assert revised.id == second.id and revised.job.status == "queued"
    assert revised.file.filename == "featuretype.STL"  # the current file until described
    client = readme["client"]
    assert ready(client, revised).file.filename == "round.stl"

    # A third part, in millimetres, with numeric metadata.
    body = BodyUploadModel(
        file=File(payload=(PARTS / "plate_holes.STL").read_bytes(), file_name="plate_holes.STL"),
        external_id="PN-1003", units=BodyUploadModelUnits.MM,
        metadata=BodyUploadModelMetadata.from_dict({"material": "aluminium", "qty": 12}),
    )
    third = ready(client, upload_model.sync(client=client, body=body))
    assert third.size is not None and third.size.units == "mm"

    def similar_to_first(**filters: Any) -> list[str]:
        return external_ids(similar_models.sync(str(first.id), client=client, **filters))

    assert sorted(similar_to_first()) == ["PN-1002", "PN-1003"]
    aluminium = MetadataFilter.from_dict({"metadata.material": "aluminium"})
    assert similar_to_first(metadata=aluminium) == ["PN-1003"]
    dozen = MetadataRanges.from_dict({"metadata.qty.gte": 10, "metadata.qty.lte": 12})
    assert similar_to_first(metadata_ranges=dozen) == ["PN-1003"]
    more = MetadataRanges.from_dict({"metadata.qty.gte": 13})
    assert similar_to_first(metadata_ranges=more) == []
    length = third.size.length
    assert similar_to_first(size_length_gte=length - 0.01, size_length_lte=length + 0.01) == [
        "PN-1003"
    ]

    found = search_by_upload.sync(
        client=client, k=3, body=BodySearchByUpload(file=File(payload=SCAN.read_bytes(),
                                                              file_name=SCAN.name)),
    )
    assert external_ids(found)[0] == "PN-1001", "the scan of angle_block finds it first"

    # Pages: every model once, newest first, by next_cursor.
    seen: list[str] = []
    cursor = ""
    while True:
        page = list_models.sync(client=client, limit=2, cursor=cursor)
        seen += [model.external_id for model in page.items]
        if page.next_cursor is None:
            break
        cursor = page.next_cursor
    assert seen == ["PN-1003", "PN-1002", "PN-1001"]
    jobs = list_jobs.sync(client=client, limit=10)
    assert len(jobs.items) == 4 and {job.status for job in jobs.items} == {"done"}

    missing = get_model.sync("00000000-0000-0000-0000-000000000000", client=client)
    assert isinstance(missing, Problem) and missing.status == 404
    assert missing.type_ == "urn:shapesearch:problem:model-not-found"
    refused = AuthenticatedClient(base_url=url, token="ss_not_a_key")
    denied = get_model.sync(str(first.id), client=refused)
    assert isinstance(denied, Problem) and denied.status == 401
