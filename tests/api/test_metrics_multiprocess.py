"""Metrics across processes: one scrape of ``/metrics`` sums every API process of
``SHAPESEARCH_API_PROCESSES``, and ``shapesearch worker --metrics-port`` exports the
describe, cutoff and queue series of its worker processes (prometheus-client's multiprocess
mode, ``app.observability.metrics``)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

import httpx
import pytest
from fastapi.testclient import TestClient
from prometheus_client.parser import text_string_to_metric_families
from sqlalchemy import create_engine, select

from app.api.main import create_app
from app.cli import build_parser
from app.db.models import Job
from app.observability.metrics import MULTIPROCESS_VARIABLE, shared_metrics_directory
from app.startup import startup_ok
from tests.conftest import FAST_QUEUE, PARTS, SMALL_ENGINE, make_settings
from tests.live_server import free_port, live_server

REQUESTS = 40
CUBE = (PARTS / "20mm-xyz-cube.stl").read_bytes()


def scrape(url: str) -> dict[tuple[str, tuple[tuple[str, str], ...]], float]:
    """Every sample of one scrape, by (name, sorted labels)."""
    text = httpx.get(url, timeout=10).text
    return {
        (sample.name, tuple(sorted(sample.labels.items()))): sample.value
        for family in text_string_to_metric_families(text)
        for sample in family.samples
    }


def total(samples: dict, name: str, **labels: str) -> float:
    """The sum of the samples of ``name`` whose labels include ``labels``."""
    wanted = set(labels.items())
    return sum(value for (n, keys), value in samples.items() if n == name and wanted <= set(keys))


def wait_for(condition: Callable[[], bool], timeout: float, what: str) -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            pytest.fail(f"{what}: not within {timeout:.0f} s")
        time.sleep(0.1)


def answering_process(response: httpx.Response) -> str:
    """The API process that answered: made-up request ids begin with 16 hex digits of their
    process (``app.observability.logs``)."""
    return response.headers["x-request-id"][:16]


def wait_for_both_processes(base: str) -> None:
    """``live_server`` returns once one process answers; the second joins the port when its
    app has started. Fresh connections (one per request) are spread over those listening."""
    seen: set[str] = set()

    def both() -> bool:
        seen.add(answering_process(httpx.get(f"{base}/healthz", timeout=10)))
        return len(seen) == 2

    wait_for(both, 120, "both API processes answering")


@pytest.mark.slow
def test_one_scrape_counts_the_requests_of_every_api_process(tmp_path: Path) -> None:
    shared = tmp_path / "metrics"
    shared.mkdir()
    # A file of an earlier run: 1000 requests of the route counted below, which serve must
    # wipe at its start (a scrape would add them up).
    subprocess.run(
        [sys.executable, "-c", "from prometheus_client import Counter; "
         "Counter('shapesearch_http_requests', '', ['method', 'route', 'status'])"
         ".labels('GET', '/v1/models', '200').inc(1000)"],
        env={**os.environ, "PROMETHEUS_MULTIPROC_DIR": str(shared)}, check=True,
    )  # fmt: skip
    assert list(shared.glob("counter_*.db"))
    env = {
        "SHAPESEARCH_API_PROCESSES": "2",
        "SHAPESEARCH_WORKERS": "0",
        "PROMETHEUS_MULTIPROC_DIR": str(shared),
    }
    with live_server(tmp_path, env, timeout=120) as base:
        wait_for_both_processes(base)
        answered = [httpx.get(f"{base}/v1/models", timeout=10) for _ in range(REQUESTS)]
        assert all(response.status_code == 200 for response in answered)
        assert len({answering_process(response) for response in answered}) == 2

        # A request is counted just after its answer is sent: wait for the last one.
        def counted() -> float:
            return total(scrape(f"{base}/metrics"), "shapesearch_http_requests_total",
                         method="GET", route="/v1/models")  # fmt: skip

        wait_for(lambda: counted() >= REQUESTS, 10, f"{REQUESTS} requests counted")
        assert counted() == REQUESTS
        samples = scrape(f"{base}/metrics")
        assert total(samples, "shapesearch_http_request_duration_seconds_count",
                     route="/v1/models") == REQUESTS  # fmt: skip
        # One series of the index gauge (the processes merged), and one live file each.
        assert samples[("shapesearch_index_models", ())] == 0
        assert samples[("shapesearch_index_neighbourhoods_kept_ratio", ())] == 1
        assert len(list(shared.glob("gauge_livemin_*.db"))) == 2
    # Stopped: the dead processes' live gauges are gone, what they counted stays.
    assert not list(shared.glob("gauge_live*"))
    assert len(list(shared.glob("counter_*.db"))) >= 2


def test_a_shared_directory_is_made_for_the_block_or_emptied_of_other_runs(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.delenv(MULTIPROCESS_VARIABLE, raising=False)
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    with shared_metrics_directory() as made:
        assert os.environ[MULTIPROCESS_VARIABLE] == made
        assert Path(made).parent == tmp_path and Path(made).is_dir()
    assert MULTIPROCESS_VARIABLE not in os.environ
    assert not Path(made).exists()

    given = tmp_path / "given"
    given.mkdir()
    for name in ("counter_1.db", "gauge_livemin_1.db", f"histogram_{os.getpid()}.db"):
        (given / name).write_bytes(b"")
    monkeypatch.setenv(MULTIPROCESS_VARIABLE, str(given))
    with shared_metrics_directory() as shared:
        assert shared == str(given)
        # An earlier run's files go; this process's own (made at its import) stay.
        assert [path.name for path in given.iterdir()] == [f"histogram_{os.getpid()}.db"]
    assert given.is_dir() and os.environ[MULTIPROCESS_VARIABLE] == str(given)


def test_a_metrics_directory_is_made_at_start_up_or_refused_in_one_line(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setenv("SHAPESEARCH_DATA_DIR", str(tmp_path))
    monkeypatch.delenv("SHAPESEARCH_DATABASE_URL", raising=False)
    blocker = tmp_path / "a-file"
    blocker.write_text("")
    monkeypatch.setenv(MULTIPROCESS_VARIABLE, str(blocker / "metrics"))
    assert not startup_ok()
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1
    assert lines[0].startswith(f"error: PROMETHEUS_MULTIPROC_DIR={blocker / 'metrics'}: ")
    assert "cannot create it" in lines[0]
    wanted = tmp_path / "new" / "metrics"
    monkeypatch.setenv(MULTIPROCESS_VARIABLE, str(wanted))
    assert startup_ok() and wanted.is_dir()


@contextmanager
def running_worker(
    database_url: str, log: Path, args: list[str], extra_env: dict[str, str] | None = None
) -> Iterator[subprocess.Popen[bytes]]:
    """``shapesearch worker ARGS`` on ``database_url`` until the block ends."""
    env = {k: v for k, v in os.environ.items() if not k.startswith("SHAPESEARCH_")}
    # No scan views: one describe per job instead of four.
    for name, value in {**SMALL_ENGINE, **FAST_QUEUE, "scan_views": 0}.items():
        env[f"SHAPESEARCH_{name.upper()}"] = str(value)
    env.update({"SHAPESEARCH_DATABASE_URL": database_url, **(extra_env or {})})
    with log.open("wb") as output:
        process = subprocess.Popen(
            [sys.executable, "-m", "app.cli", "worker", *args],
            env=env, stdout=output, stderr=subprocess.STDOUT,
        )  # fmt: skip
        try:
            yield process
        finally:
            process.send_signal(signal.SIGTERM)
            try:
                process.wait(60)
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()


def started_workers(log: Path) -> int:
    """Worker loops that logged "worker ID started" (JSON lines)."""
    lines = [json.loads(line) for line in log.read_text(errors="replace").splitlines()
             if line.startswith("{") and line.endswith("}")]  # fmt: skip
    return sum(
        line.get("logger") == "shapesearch.worker" and line["message"].endswith(" started")
        for line in lines
    )


@pytest.mark.slow
def test_worker_processes_export_their_describes_on_one_port(tmp_path: Path) -> None:
    """Two jobs, queued once both worker processes poll: each is described in a process of
    its own, and one scrape of the worker's metrics port counts both."""
    database_url = f"sqlite:///{tmp_path / 'shapesearch.db'}"
    port = free_port()
    metrics = f"http://127.0.0.1:{port}/metrics"
    log = tmp_path / "worker.log"
    args = ["--concurrency", "2", "--metrics-port", str(port)]
    app = create_app(make_settings(database_url))  # no embedded worker: the jobs stay queued
    with TestClient(app) as client, running_worker(database_url, log, args) as worker:
        wait_for(lambda: worker.poll() is None and started_workers(log) == 2, 120,
                 "two worker processes polling (see worker.log)")  # fmt: skip
        assert total(scrape(metrics), "shapesearch_describe_seconds_count") == 0
        for number in range(2):
            response = client.post(
                "/v1/models",
                files={"file": (f"cube{number}.stl", CUBE, "application/octet-stream")},
            )
            assert response.status_code == 202, response.text
        wait_for(lambda: scrape(metrics)[("shapesearch_jobs", (("status", "done"),))] == 2,
                 120, "the jobs described")  # fmt: skip
        samples = scrape(metrics)
    assert total(samples, "shapesearch_describe_seconds_count", stage="total") == 2
    assert total(samples, "shapesearch_cutoff_n_count") == 2
    assert total(samples, "shapesearch_solver_calls_total") >= 2
    assert samples[("shapesearch_queue_depth", ())] == 0
    assert ("shapesearch_index_models", ()) not in samples  # workers hold no index
    engine = create_engine(database_url)
    with engine.connect() as connection:
        workers = connection.scalars(select(Job.worker_id)).all()
    engine.dispose()
    assert len({worker_id.split(":")[1] for worker_id in workers}) == 2  # two pids


@pytest.mark.slow
def test_one_worker_process_serves_its_metrics_and_a_second_cannot_share_the_port(
    tmp_path: Path,
) -> None:
    """``--concurrency 1`` works in its own process, with its plain registry (the process_*
    series only it has), on the port of SHAPESEARCH_WORKER_METRICS_PORT."""
    database_url = f"sqlite:///{tmp_path / 'shapesearch.db'}"
    port = free_port()
    metrics = f"http://127.0.0.1:{port}/metrics"
    env = {"SHAPESEARCH_WORKER_METRICS_PORT": str(port)}
    with running_worker(database_url, tmp_path / "first.log", ["--concurrency", "1"], env):
        wait_for(lambda: started_workers(tmp_path / "first.log") == 1, 120, "the worker")
        samples = scrape(metrics)
        assert samples[("shapesearch_queue_depth", ())] == 0
        assert samples[("process_cpu_seconds_total", ())] > 0
        assert ("shapesearch_cutoff_n_count", ()) in samples
        second = tmp_path / "second.log"
        with running_worker(database_url, second, ["--concurrency", "1"], env) as refused:
            assert refused.wait(60) == 1
        assert f"error: cannot serve metrics on 127.0.0.1:{port}" in second.read_text()


@pytest.mark.parametrize("port", ["0", "65536", "http"])
def test_the_metrics_port_must_be_a_port(port: str, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exit_:
        build_parser().parse_args(["worker", "--metrics-port", port])
    assert exit_.value.code == 2
    assert "is not a port number (1-65535)" in capsys.readouterr().err
