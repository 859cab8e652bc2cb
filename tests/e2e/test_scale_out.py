"""Scale-out on the real PostgreSQL: two API processes (``shapesearch serve --no-worker``) and
two workers (``shapesearch worker``), one shared database, each API process holding its
own index. A model described by a worker is found by both API processes within the sync
interval, and a delete through one API process leaves the other's answers within it."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import IO

import httpx
import pytest

from tests.conftest import PARTS, SMALL_ENGINE

SYNC_INTERVAL = 0.5
# The bound checked: the sync interval, plus room for one sync and a request on a shared,
# noisy 2-core machine.
SLACK = 3.0
SHAPESEARCH = str(Path(sys.executable).parent / "shapesearch")


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def wait_until(condition: Callable[[], bool], timeout: float, what: str) -> float:
    """Poll ``condition``; seconds it took, or fail after ``timeout``."""
    start = time.monotonic()
    while not condition():
        if time.monotonic() - start > timeout:
            pytest.fail(f"{what}: not within {timeout:.1f} s")
        time.sleep(0.05)
    return time.monotonic() - start


class Cluster:
    """The processes of one deployment; stopped (and waited for) at the end."""

    def __init__(self, database_url: str) -> None:
        self.env = {
            **os.environ,
            "SHAPESEARCH_DATABASE_URL": database_url,
            "SHAPESEARCH_INDEX_SYNC_INTERVAL": str(SYNC_INTERVAL),
            "SHAPESEARCH_POLL_INTERVAL": "0.1",
            "SHAPESEARCH_SHUTDOWN_GRACE_SECONDS": "5",
            **{f"SHAPESEARCH_{name.upper()}": str(value) for name, value in SMALL_ENGINE.items()},
        }
        self.processes: list[subprocess.Popen[bytes]] = []
        self._logs: dict[int, IO[bytes]] = {}

    def start(self, *args: str) -> subprocess.Popen[bytes]:
        # Its log goes to a file: a pipe nobody reads while the test runs fills after ~250
        # access lines, and then the process blocks in a logging write, every request with
        # it (a status poll timed out after 30 s while two workers described).
        log = tempfile.TemporaryFile()  # noqa: SIM115 (closed by stop)
        process = subprocess.Popen(
            [SHAPESEARCH, *args], env=self.env, stdout=subprocess.DEVNULL, stderr=log
        )
        self.processes.append(process)
        self._logs[process.pid] = log
        return process

    def stderr(self, process: subprocess.Popen[bytes]) -> bytes:
        """What ``process`` wrote to its stderr so far."""
        log = self._logs[process.pid]
        log.seek(0)
        return log.read()

    def api(self) -> httpx.Client:
        port = free_port()
        process = self.start("serve", "--no-worker", "--port", str(port))
        client = httpx.Client(base_url=f"http://127.0.0.1:{port}", timeout=30)

        def ready() -> bool:
            if process.poll() is not None:
                pytest.fail(f"API process exited: {self.stderr(process).decode()[-2000:]}")
            try:
                return client.get("/readyz").status_code == 200
            except httpx.HTTPError:
                return False

        wait_until(ready, 60, "API process ready")
        return client

    def stop(self) -> None:
        for process in self.processes:
            process.terminate()
        for process in self.processes:
            try:
                process.wait(20)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()
        for log in self._logs.values():
            log.close()


@pytest.fixture
def cluster(new_database_url: Callable[[str], str]) -> Iterator[Cluster]:
    deployment = Cluster(new_database_url("postgresql"))
    try:
        yield deployment
    finally:
        deployment.stop()


def similar_ids(client: httpx.Client, model_id: str) -> set[str]:
    response = client.get(f"/v1/models/{model_id}/similar", params={"k": 10})
    assert response.status_code == 200, response.text
    return {result["model"]["id"] for result in response.json()["results"]}


@pytest.mark.slow
def test_two_apis_and_two_workers_share_one_postgresql(cluster: Cluster) -> None:
    first = cluster.api()  # migrates the schema before the others start
    second = cluster.api()
    cluster.start("worker", "--concurrency", "1")
    cluster.start("worker", "--concurrency", "1")

    ids = []
    for name in ("20mm-xyz-cube.stl", "cylinder.stl"):
        path = PARTS / name
        response = first.post(
            "/v1/models", files={"file": (name, path.read_bytes(), "application/octet-stream")}
        )
        assert response.status_code == 202, response.text
        ids.append(response.json()["id"])
    anchor, other = ids

    def described() -> bool:
        return all(first.get(f"/v1/models/{i}").json()["status"] == "ready" for i in ids)

    wait_until(described, 120, "both models described by the workers")
    # Found by both API processes within the sync interval (plus slack).
    for api in (first, second):
        wait_until(lambda api=api: other in similar_ids(api, anchor), SYNC_INTERVAL + SLACK,
                   "the new model in the similar answers of each API process")  # fmt: skip

    assert first.delete(f"/v1/models/{other}").status_code == 204
    assert other not in similar_ids(first, anchor)  # the deleting process: at once
    wait_until(lambda: other not in similar_ids(second, anchor), SYNC_INTERVAL + SLACK,
               "the deleted model gone from the other API process")  # fmt: skip
    assert second.get(f"/v1/models/{other}").status_code == 404
    for api in (first, second):
        assert api.get("/readyz").status_code == 200


def answering_processes(base_url: str, path: str, tries: int = 200) -> dict[str, dict]:
    """The JSON answers of ``path`` by the API process that served them, each request on a
    fresh connection (the kernel hands connections to the processes sharing the port). A
    process is known by its made-up request ids' first 16 hex digits
    (``app.observability.logs``)."""
    answers: dict[str, dict] = {}
    for _ in range(tries):
        response = httpx.get(base_url + path, timeout=30)
        assert response.status_code == 200, response.text
        answers[response.headers["x-request-id"][:16]] = response.json()
        if len(answers) == 2:
            break
    return answers


@pytest.mark.slow
def test_one_serve_runs_several_api_processes_on_its_port(
    new_database_url: Callable[[str], str],
) -> None:
    """SHAPESEARCH_API_PROCESSES=2 on the embedded default (SQLite, the worker shared out):
    two processes answer on one port, each finds a new model and drops a deleted one."""
    deployment = Cluster(new_database_url("sqlite"))
    deployment.env.update({"SHAPESEARCH_API_PROCESSES": "2", "SHAPESEARCH_WORKERS": "2"})
    try:
        port = free_port()
        process = deployment.start("serve", "--port", str(port))
        base_url = f"http://127.0.0.1:{port}"
        client = httpx.Client(base_url=base_url, timeout=30)

        def ready() -> bool:
            assert process.poll() is None, deployment.stderr(process).decode()[-2000:]
            try:
                return client.get("/readyz").status_code == 200
            except httpx.HTTPError:
                return False

        wait_until(ready, 60, "serve ready")
        ids = []
        for name in ("20mm-xyz-cube.stl", "cylinder.stl"):
            response = client.post(
                "/v1/models",
                files={"file": (name, (PARTS / name).read_bytes(), "application/octet-stream")},
            )
            assert response.status_code == 202, response.text
            ids.append(response.json()["id"])
        anchor, other = ids
        wait_until(
            lambda: all(client.get(f"/v1/models/{i}").json()["status"] == "ready" for i in ids),
            120,
            "both models described by the embedded workers",
        )
        similar = f"/v1/models/{anchor}/similar?k=10"

        def both_find(present: bool) -> bool:
            answers = answering_processes(base_url, similar)
            assert len(answers) == 2, "one process answered every connection"
            found = [
                other in {r["model"]["id"] for r in answer["results"]}
                for answer in answers.values()
            ]
            return all(f == present for f in found)

        wait_until(lambda: both_find(True), SYNC_INTERVAL + SLACK, "the new model in both")
        assert client.delete(f"/v1/models/{other}").status_code == 204
        wait_until(lambda: both_find(False), SYNC_INTERVAL + SLACK, "the deleted model in none")

        # One API process dies: serve stops the other and exits non-zero, for the service
        # manager to restart it whole (a half-served port would hide the failure).
        first, second = api_processes(process.pid)
        os.kill(first, signal.SIGKILL)
        assert process.wait(60) == 1
        assert gone(second)
    finally:
        deployment.stop()


def api_processes(serve_pid: int) -> list[int]:
    """The API processes (multiprocessing spawn children) of a ``serve`` process."""
    try:
        children = Path(f"/proc/{serve_pid}/task/{serve_pid}/children").read_text().split()
    except FileNotFoundError:
        return []
    return [
        int(pid)
        for pid in children
        if b"spawn_main" in Path(f"/proc/{pid}/cmdline").read_bytes()
    ]


@pytest.mark.slow
def test_several_api_processes_stop_on_sigterm_and_refuse_a_taken_port(
    new_database_url: Callable[[str], str],
) -> None:
    deployment = Cluster(new_database_url("sqlite"))
    deployment.env.update({"SHAPESEARCH_API_PROCESSES": "2", "SHAPESEARCH_WORKERS": "0"})
    try:
        with socket.socket() as taken:
            taken.bind(("127.0.0.1", 0))
            taken.listen()
            refused = deployment.start("serve", "--port", str(taken.getsockname()[1]))
            assert refused.wait(60) == 1
            assert b"cannot listen on 127.0.0.1" in deployment.stderr(refused)

        port = free_port()
        process = deployment.start("serve", "--port", str(port))
        wait_until(lambda: len(api_processes(process.pid)) == 2, 60, "two API processes")
        children = api_processes(process.pid)
        wait_until(
            lambda: httpx.get(f"http://127.0.0.1:{port}/healthz").status_code == 200
            if _port_open(port)
            else False,
            60,
            "serve answering",
        )
        process.send_signal(signal.SIGTERM)
        assert process.wait(60) == 0  # asked to stop: a clean exit
        assert all(gone(child) for child in children)
    finally:
        deployment.stop()


def gone(pid: int) -> bool:
    """The process has exited (a zombie that nobody reaped yet counts as exited)."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] == "Z"
    except FileNotFoundError:
        return True


def _port_open(port: int) -> bool:
    with socket.socket() as probe:
        return probe.connect_ex(("127.0.0.1", port)) == 0
