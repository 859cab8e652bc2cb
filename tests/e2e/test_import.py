"""``shapesearch import`` against the app served by a real uvicorn on 127.0.0.1 (fake
describer): counts, exit code, CSV report, resumability, metadata sidecar, a zip archive."""

from __future__ import annotations

import csv
import json
import shutil
import socket
import threading
import time
import zipfile
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

import httpx
import pytest
import uvicorn
from fastapi import FastAPI

from app.api.main import create_app
from app.cli import main
from tests.assembly_files import assembly_3mf, assembly_glb, rotated_a_stl
from tests.conftest import EDGE_CASES, PARTS, fake_describe, make_settings
from tests.plm_helpers import box_stl

GOOD_PARTS = sorted(p for p in PARTS.iterdir() if p.suffix.lower() == ".stl")


@pytest.fixture
def service(database_url: str) -> Iterator[str]:
    """The app on a free 127.0.0.1 port, with an embedded worker."""
    app = create_app(make_settings(database_url, workers=1), embedded_worker=True,
                     job_handler=fake_describe)
    with served(app) as url:
        yield url


@contextmanager
def served(app: FastAPI) -> Iterator[str]:
    """Serve ``app`` on a free 127.0.0.1 port for the block; stop it (and its worker)
    after."""
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    server = uvicorn.Server(uvicorn.Config(app, host="127.0.0.1", port=port, log_level="error"))
    thread = threading.Thread(target=server.run, daemon=True)
    thread.start()
    deadline = time.monotonic() + 30
    while not server.started:
        assert time.monotonic() < deadline and thread.is_alive(), "uvicorn did not start"
        time.sleep(0.05)
    try:
        yield f"http://127.0.0.1:{port}"
    finally:
        server.should_exit = True
        thread.join(30)


@pytest.fixture
def catalogue(tmp_path: Path) -> Path:
    """20 shape files (2 bad) in a folder with a sub-folder, plus files that are not shapes."""
    folder = tmp_path / "catalogue"
    (folder / "sub").mkdir(parents=True)
    for part in GOOD_PARTS:
        shutil.copy(part, folder / part.name)
    count = len(GOOD_PARTS)
    for i in range(18 - count):
        (folder / "sub" / f"box-{i}.stl").write_bytes(box_stl(1.0 + i / 10))
    shutil.copy(EDGE_CASES / "empty.stl", folder / "sub" / "empty.stl")
    (folder / "broken.ply").write_bytes(b"ply\nformat ascii 1.0\nelement vertex 9\nend_header\n1 2")
    (folder / "README.md").write_text("not a part")
    (folder / ".hidden.stl").write_bytes(box_stl(9.0))
    return folder


def read_report(path: Path) -> list[dict[str, str]]:
    with path.open(newline="") as handle:
        return list(csv.DictReader(handle))


@pytest.mark.slow
def test_a_folder_is_imported_then_a_second_run_uploads_nothing(
    service: str, catalogue: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    sidecar = tmp_path / "meta.json"
    sidecar.write_text(json.dumps({"sub/box-0.stl": {"material": "steel"}}))
    report = tmp_path / "first.csv"
    code = main(["import", str(catalogue), "--url", service, "--metadata", str(sidecar),
                 "--concurrency", "3", "--wait", "--report", str(report)])
    assert code == 1  # two files were refused
    rows = read_report(report)
    assert len(rows) == 20
    outcomes = {row["path"]: row["outcome"] for row in rows}
    assert outcomes.pop("sub/empty.stl") == "refused"
    assert outcomes.pop("broken.ply") == "refused"
    assert set(outcomes.values()) == {"ready"}
    refused = [row for row in rows if row["outcome"] == "refused"]
    assert all(row["http_status"] == "422" and row["detail"] for row in refused)
    assert "18 ready" in capsys.readouterr().err

    models = httpx.get(f"{service}/v1/models", params={"limit": 100}).json()["items"]
    assert len(models) == 18
    by_external_id = {m["external_id"]: m for m in models}
    assert by_external_id["sub/box-0.stl"]["metadata"] == {"material": "steel"}
    assert by_external_id["sub/box-0.stl"]["status"] == "ready"

    second = tmp_path / "second.csv"
    monkeypatch.setenv("SHAPESEARCH_URL", service)  # the URL from the environment this time
    code = main(["import", str(catalogue), "--report", str(second)])
    assert code == 1  # the two bad files are refused again
    again = {row["path"]: row["outcome"] for row in read_report(second)}
    assert [p for p, o in again.items() if o not in ("skipped", "refused")] == []
    assert sum(o == "skipped" for o in again.values()) == 18
    jobs = httpx.get(f"{service}/v1/jobs", params={"limit": 100}).json()["items"]
    assert len(jobs) == 18  # nothing was uploaded or described again
    assert {job["background"] for job in jobs} == {True}  # a bulk load: it takes turns


def test_assemblies_are_split_and_their_parts_and_instances_reported(
    service: str, tmp_path: Path, capsys: pytest.CaptureFixture[str],
) -> None:
    folder = tmp_path / "products"
    folder.mkdir()
    (folder / "frame.glb").write_bytes(assembly_glb())  # A 4 times, B once
    (folder / "fixture.3mf").write_bytes(assembly_3mf(a_count=3))  # A 3 times, B once
    (folder / "bracket.stl").write_bytes(rotated_a_stl())  # a loose part
    report = tmp_path / "report.csv"
    code = main(["import", str(folder), "--url", service, "--assembly", "split",
                 "--report", str(report)])
    assert code == 0
    rows = {row["path"]: row for row in read_report(report)}
    assert (rows["frame.glb"]["parts"], rows["frame.glb"]["instances"]) == ("2", "5")
    assert (rows["fixture.3mf"]["parts"], rows["fixture.3mf"]["instances"]) == ("2", "4")
    assert (rows["bracket.stl"]["parts"], rows["bracket.stl"]["instances"]) == ("", "")
    assert "2 assemblies split: 4 parts created, 9 instances found" in capsys.readouterr().err
    models = httpx.get(f"{service}/v1/models", params={"limit": 100}).json()["items"]
    assert len(models) == 3 + 4
    # Whole: one model a file, nothing counted.
    whole = tmp_path / "whole.csv"
    (folder / "frame.glb").write_bytes(assembly_glb(with_b=False))  # changed: sent again
    assert main(["import", str(folder), "--url", service, "--assembly", "whole",
                 "--report", str(whole)]) == 0
    assert {row["parts"] for row in read_report(whole)} == {""}


@pytest.mark.slow
def test_a_zip_archive_with_stems_as_external_ids(
    service: str, tmp_path: Path
) -> None:
    archive = tmp_path / "parts.zip"
    with zipfile.ZipFile(archive, "w") as zipped:
        for i in range(3):
            zipped.writestr(f"lib/bracket-{i}.stl", box_stl(1.0, 1.0 + i))
        zipped.writestr("lib/notes.txt.bak", b"x")
    report = tmp_path / "zip.csv"
    code = main(["import", str(archive), "--url", service, "--external-id", "stem",
                 "--wait", "--report", str(report)])
    assert code == 0
    rows = read_report(report)
    assert sorted(row["external_id"] for row in rows) == ["bracket-0", "bracket-1", "bracket-2"]
    assert {row["outcome"] for row in rows} == {"ready"}
    assert main(["import", str(archive), "--url", service, "--external-id", "stem",
                 "--report", str(report)]) == 0
    assert {row["outcome"] for row in read_report(report)} == {"skipped"}


def test_an_unreachable_service_fails_with_a_clear_error(
    tmp_path: Path, catalogue: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    code = main(["import", str(catalogue), "--url", f"http://127.0.0.1:{port}",
                 "--retries", "1", "--report", str(tmp_path / "r.csv")])
    assert code == 2
    assert "error" in capsys.readouterr().err.lower()


def test_the_catalogue_is_pulled_only_as_uploads_finish() -> None:
    """A catalogue of 1,000 files is not drained before the first upload: with every upload
    held, exactly 2 x concurrency items have been pulled (each holds at most one file)."""
    from app.cli.importer import Outcome, SourceItem, upload_all

    pulled = 0
    release = threading.Event()

    def catalogue() -> Iterator[SourceItem]:
        nonlocal pulled
        for i in range(1000):
            pulled += 1
            yield SourceItem(f"part-{i}.stl", 3, lambda: b"abc")

    def upload(item: SourceItem) -> Outcome:
        release.wait(30)
        return Outcome(item.path, item.path, "", "accepted")

    outcomes: list[Outcome] = []
    seen: list[str] = []
    runner = threading.Thread(
        target=upload_all, args=(catalogue(), upload, 3, lambda o: seen.append(o.path), outcomes)
    )
    runner.start()
    try:
        deadline = time.monotonic() + 10
        while pulled < 6 and time.monotonic() < deadline:
            time.sleep(0.01)
        time.sleep(0.2)  # time for the producer to over-pull, if it would
        assert pulled == 6
    finally:
        release.set()
        runner.join(30)
    assert pulled == 1000
    assert sorted(o.path for o in outcomes) == sorted(f"part-{i}.stl" for i in range(1000))
    assert len(seen) == 1000


def test_the_default_file_limit_is_the_services_upload_limit() -> None:
    from app.cli.importer import DEFAULT_MAX_FILE_BYTES
    from app.settings import Settings

    assert Settings.model_fields["max_upload_bytes"].default == DEFAULT_MAX_FILE_BYTES


def test_archive_members_are_read_when_uploaded_and_unsafe_names_are_refused(
    tmp_path: Path,
) -> None:
    """Zip members are read lazily (after the listing, from the archive that stays open);
    names that climb out of the archive and members over the limit are refused unread."""
    from app.cli.importer import open_sources

    archive = tmp_path / "parts.zip"
    with zipfile.ZipFile(archive, "w", zipfile.ZIP_DEFLATED) as zipped:
        zipped.writestr("a/good.stl", box_stl(1.0))
        zipped.writestr("../escape.stl", box_stl(2.0))
        zipped.writestr("/etc/absolute.stl", box_stl(3.0))
        zipped.writestr("C:\\windows.stl", box_stl(4.0))
        zipped.writestr("big.stl", b"x" * 5000)
        zipped.writestr("notes.md", b"not a shape")
    with open_sources(archive, max_bytes=4000) as sources:
        items = list(sources)
        by_path = {item.path: item for item in items}
        assert by_path["a/good.stl"].read() == box_stl(1.0)  # read after the listing
    assert sorted(by_path) == sorted(["a/good.stl", "../escape.stl", "/etc/absolute.stl",
                                      "C:\\windows.stl", "big.stl"])
    assert by_path["a/good.stl"].refusal is None
    for name in ("../escape.stl", "/etc/absolute.stl", "C:\\windows.stl"):
        assert "unsafe path" in (by_path[name].refusal or "")
    assert "larger than the upload limit of 4000" in (by_path["big.stl"].refusal or "")


@pytest.mark.slow
def test_a_tar_archive_is_streamed_member_by_member(service: str, tmp_path: Path) -> None:
    """A .tar.gz through the live service: its parts are imported, a traversal name and a
    member over --max-file-bytes are refused with a reason (and never uploaded)."""
    import io
    import tarfile

    archive = tmp_path / "parts.tar.gz"
    members = {f"lib/part-{i}.stl": box_stl(1.0 + i) for i in range(4)}
    members["../../outside.stl"] = box_stl(7.0)
    members["lib/huge.stl"] = b"solid x\n" + b" " * 20_000
    with tarfile.open(archive, "w:gz") as tarred:
        for name, content in members.items():
            info = tarfile.TarInfo(name)
            info.size = len(content)
            tarred.addfile(info, io.BytesIO(content))
    report = tmp_path / "tar.csv"
    code = main(["import", str(archive), "--url", service, "--max-file-bytes", "10000",
                 "--concurrency", "2", "--report", str(report)])
    assert code == 1  # two members refused
    rows = {row["path"]: row for row in read_report(report)}
    assert {p: r["outcome"] for p, r in rows.items()} == {
        **{f"lib/part-{i}.stl": "accepted" for i in range(4)},
        "../../outside.stl": "refused", "lib/huge.stl": "refused",
    }
    assert "unsafe path" in rows["../../outside.stl"]["detail"]
    assert "larger than the upload limit" in rows["lib/huge.stl"]["detail"]
    models = httpx.get(f"{service}/v1/models", params={"limit": 100}).json()["items"]
    assert sorted(m["external_id"] for m in models) == [f"lib/part-{i}.stl" for i in range(4)]


class Answers:
    """A MockTransport handler that answers from a script and records every request."""

    def __init__(self, *answers: tuple[int, dict[str, str]] | Exception) -> None:
        self.answers = list(answers)
        self.requests: list[tuple[str, bytes]] = []

    def __call__(self, request: httpx.Request) -> httpx.Response:
        self.requests.append((request.method, request.read()))
        answer = self.answers.pop(0) if self.answers else (201, {})
        if isinstance(answer, Exception):
            raise answer
        status, headers = answer
        body = {"id": "m-1"} if status < 300 else {"title": "Refused", "detail": f"no {status}"}
        return httpx.Response(status, headers=headers, json=body)


def mock_client(handler: Answers, retries: int = 5) -> httpx.Client:
    from app.cli.importer import ImportOptions, make_client

    return make_client(ImportOptions(url="http://catalogue.test", retries=retries),
                       transport=httpx.MockTransport(handler))


@pytest.fixture
def sleeps(monkeypatch: pytest.MonkeyPatch) -> list[float]:
    """The retry layer's waits, recorded instead of slept."""
    import httpx_retries.retry

    waited: list[float] = []
    monkeypatch.setattr(httpx_retries.retry.time, "sleep", waited.append)
    return waited


def test_an_upload_is_retried_after_retry_after_and_resent_whole(sleeps: list[float]) -> None:
    from app.cli.importer import _upload

    handler = Answers((503, {"Retry-After": "2"}), httpx.ConnectError("refused"),
                      (429, {"Retry-After": "0"}), (201, {}))
    client = mock_client(handler)
    content = box_stl(2.0)
    outcome = _upload(client, "a/b.stl", content, "sha", "a/b.stl", {"k": "v"})
    assert (outcome.outcome, outcome.http_status, outcome.model_id) == ("accepted", 201, "m-1")
    assert [method for method, _ in handler.requests] == ["PUT"] * 4
    bodies = {body for _, body in handler.requests}
    assert len(bodies) == 1 and content in bodies.pop()  # every retry sends the whole file
    assert sleeps[0] == 2.0  # the service's Retry-After
    assert 0.0 <= sleeps[1] <= 0.25 * 2**2 and 0.0 <= sleeps[2] <= 0.25 * 2**3  # backoff
    client.close()


def test_backoff_is_jittered_and_gives_up_with_the_last_answer(sleeps: list[float]) -> None:
    from app.cli.importer import _upload

    handler = Answers(*[(502, {}), (504, {}), (503, {})] * 2, (503, {}), (201, {}))
    client = mock_client(handler, retries=6)
    outcome = _upload(client, "p.stl", b"solid", "sha", "p.stl", None)
    assert (outcome.outcome, outcome.http_status) == ("failed", 503)
    assert len(handler.requests) == 7
    assert len(sleeps) == 6
    assert all(0.0 <= s <= 0.25 * 2 ** (i + 1) for i, s in enumerate(sleeps))
    assert len(set(sleeps)) > 1  # jitter: the threads do not retry in step
    client.close()


@pytest.mark.parametrize("status", [400, 401, 413, 415, 422])
def test_a_4xx_is_not_retried(sleeps: list[float], status: int) -> None:
    from app.cli.importer import _upload

    handler = Answers((status, {"Retry-After": "1"}))
    client = mock_client(handler)
    outcome = _upload(client, "p.stl", b"solid", "sha", "p.stl", None)
    assert (outcome.outcome, outcome.http_status) == ("refused", status)
    assert outcome.detail == f"no {status}"
    assert len(handler.requests) == 1 and sleeps == []
    client.close()


@pytest.mark.slow
def test_a_full_service_stops_the_import_and_a_second_run_completes_it(
    new_database_url: Callable[[str], str], catalogue: Path, tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    from tests.api.test_storage_full import cap_growth

    app = create_app(make_settings(new_database_url("sqlite"), workers=1),
                     embedded_worker=True, job_handler=fake_describe)
    with served(app) as service:
        lift = cap_growth(app.state.services.engine)
        report = tmp_path / "full.csv"
        code = main(["import", str(catalogue), "--url", service, "--concurrency", "1",
                     "--report", str(report)])
        assert code == 1
        rows = read_report(report)
        # One upload met the full storage (the bad files before it, if any, were refused
        # without being stored); no file after it was sent, to be refused whole.
        answered = [row["http_status"] for row in rows if row["http_status"]]
        assert answered[-1] == "507" and set(answered[:-1]) <= {"422"}
        unsent = [row for row in rows if not row["http_status"]]
        assert len(rows) == 20 and len(unsent) == 20 - len(answered) >= 16
        assert all(row["outcome"] == "failed" and "not sent" in row["detail"] for row in unsent)
        assert f"storage is full (507): {len(unsent)} file(s) not sent" in capsys.readouterr().err

        lift()
        code = main(["import", str(catalogue), "--url", service, "--report", str(report)])
        assert code == 1  # the two bad files
        outcomes = [row["outcome"] for row in read_report(report)]
        assert outcomes.count("accepted") == 18
