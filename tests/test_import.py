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
from collections.abc import Iterator
from pathlib import Path

import pytest
import uvicorn
from conftest import EDGE_CASES, PARTS, fake_describe, make_settings
from plm_helpers import box_stl

from app.api.main import create_app
from app.cli import main

GOOD_PARTS = sorted(p for p in PARTS.iterdir() if p.suffix.lower() == ".stl")


@pytest.fixture
def service(database_url: str) -> Iterator[str]:
    """The app on a free 127.0.0.1 port, with an embedded worker."""
    app = create_app(make_settings(database_url, workers=1), embedded_worker=True,
                     job_handler=fake_describe)
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
    yield f"http://127.0.0.1:{port}"
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

    import httpx

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


def test_the_client_retries_429_and_503_then_succeeds() -> None:
    from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

    from app.cli.importer import ImportOptions, _Client

    answers = [(429, {"Retry-After": "0"}), (503, {}), (200, {})]
    seen: list[str] = []

    class Flaky(BaseHTTPRequestHandler):
        def do_GET(self) -> None:  # noqa: N802 (http.server's naming)
            seen.append(self.path)
            status, headers = answers.pop(0) if answers else (200, {})
            self.send_response(status)
            for name, value in headers.items():
                self.send_header(name, value)
            self.send_header("content-length", "2")
            self.end_headers()
            self.wfile.write(b"{}")

        def log_message(self, *args: object) -> None:
            pass

    server = ThreadingHTTPServer(("127.0.0.1", 0), Flaky)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        url = f"http://127.0.0.1:{server.server_address[1]}"
        client = _Client(ImportOptions(url=url, retries=3))
        assert client.request("GET", "/v1/models").status_code == 200
        assert len(seen) == 3
        answers[:] = [(503, {}), (503, {})]
        seen.clear()
        client.retries = 1  # gives up: the last answer is returned
        assert client.request("GET", "/v1/models").status_code == 503
        assert len(seen) == 2
        client.close()
    finally:
        server.shutdown()
        server.server_close()
