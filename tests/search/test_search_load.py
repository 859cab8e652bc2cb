"""POST /v1/search under load, against a real server: with a cap of 2 concurrent describes,
20 concurrent searches get answers or 503 + Retry-After, /healthz stays fast throughout,
the server does not grow, and a file seen before is answered without describing it."""

from __future__ import annotations

import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import httpx
import numpy as np
import pytest

from tests.conftest import SMALL_ENGINE
from tests.servers import peak_memory_bytes, running_server
from tests.shapes import sphere_points

pytestmark = pytest.mark.skipif(
    not Path("/proc/self/status").exists(), reason="peak memory is read from /proc"
)

# /healthz while searches are described: the 100 ms for 95 % of the probes (before
# admission control the 95th percentile was about 0.3 s here), and a ceiling for every probe
# that still catches waiting behind a describe (seconds) but not one scheduling hiccup of a
# shared, loaded 2-core machine (one probe of 0.27 s was seen with the whole suite running).
HEALTH_LATENCY_P95 = 0.100
HEALTH_LATENCY_MAX = 1.0
PEAK_MEMORY_BOUND = 500 * 1024 * 1024


def scan(seed: int) -> bytes:
    """A distinct point cloud per seed (so no search is answered from the cache)."""
    points = sphere_points(3000, seed=seed) * np.array([1.0, 1.0 + seed / 40, 1.0])
    return "\n".join(f"{x:.6f} {y:.6f} {z:.6f}" for x, y, z in points).encode()


@pytest.mark.slow
def test_concurrent_searches_are_bounded_and_health_stays_fast(tmp_path: Path) -> None:
    settings = {**SMALL_ENGINE, "search_max_concurrent": 2, "search_retry_after_seconds": 7}
    with running_server(tmp_path, **settings) as (base, pid):
        files = [scan(seed) for seed in range(20)]
        done = threading.Event()
        latencies: list[float] = []

        def watch_health() -> None:
            with httpx.Client(base_url=base, timeout=10) as client:
                client.get("/healthz")  # connect first: not what is measured
                while not done.is_set():
                    started = time.perf_counter()
                    assert client.get("/healthz").status_code == 200
                    latencies.append(time.perf_counter() - started)
                    time.sleep(0.02)

        # One client for all searches: building one per request (an SSL context each)
        # would hold this process's GIL and delay the health probe, not the server.
        searcher = httpx.Client(
            base_url=base, timeout=300, limits=httpx.Limits(max_connections=20)
        )

        def search(content: bytes) -> httpx.Response:
            return searcher.post(
                "/v1/search", files={"file": ("scan.xyz", content, "text/plain")}
            )

        watcher = threading.Thread(target=watch_health)
        watcher.start()
        try:
            with ThreadPoolExecutor(20) as pool:
                responses = list(pool.map(search, files))
        finally:
            done.set()
            watcher.join()

        statuses = [r.status_code for r in responses]
        assert set(statuses) <= {200, 503}, statuses
        assert statuses.count(200) >= 1 and statuses.count(503) >= 1, statuses
        for refused in (r for r in responses if r.status_code == 503):
            assert refused.headers["retry-after"] == "7"
            assert refused.json()["type"] == "urn:shapesearch:problem:busy"
        assert len(latencies) >= 10
        assert np.quantile(latencies, 0.95) < HEALTH_LATENCY_P95, sorted(latencies)[-5:]
        assert max(latencies) < HEALTH_LATENCY_MAX, sorted(latencies)[-5:]
        assert peak_memory_bytes(pid) < PEAK_MEMORY_BOUND

        # The same bytes again: answered from the cache, alone and identical.
        answered = next(i for i, r in enumerate(responses) if r.status_code == 200)
        again = search(files[answered])
        assert again.status_code == 200
        assert again.json() == responses[answered].json()
        repeats = [search(files[answered]) for _ in range(3)]
        assert all(r.status_code == 200 for r in repeats), [
            (r.status_code, r.text[:200]) for r in repeats
        ]
        searcher.close()


@pytest.mark.slow
def test_identical_uploads_are_described_once(
    database_url: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The same bytes again are answered from the cache; bytes that a ready model of the
    tenant was made from are answered from that model; neither starts a describe."""
    from fastapi.testclient import TestClient

    from app.api.main import create_app
    from tests.conftest import fake_describe, make_settings, wait_for_status

    app = create_app(make_settings(database_url), embedded_worker=True)
    describer = app.state.search_describer
    calls: list[bytes] = []

    def columns(content: bytes, filename: str) -> dict:
        return {**fake_describe(content, filename), "descriptor_version": describer.version}

    class CountingSandbox:
        def run(self, function, content, filename, *_):  # noqa: ANN001, ANN002, ANN201
            calls.append(content)
            return columns(content, filename)

    # Every describe of a search goes through a sandbox made for its file's size.
    monkeypatch.setattr("app.api.search_describer.describe_sandbox",
                        lambda settings, size_bytes: CountingSandbox())
    with TestClient(app) as client:
        first, second = scan(1), scan(2)
        answers = [
            client.post("/v1/search", files={"file": ("a.xyz", first, "text/plain")})
            for _ in range(3)
        ]
        assert [a.status_code for a in answers] == [200, 200, 200]
        assert answers[0].json() == answers[2].json()
        assert calls == [first]

    stored_app = create_app(make_settings(database_url), embedded_worker=True, job_handler=columns)
    with TestClient(stored_app) as client:
        model = client.post(
            "/v1/models", files={"file": ("b.xyz", second, "text/plain")}
        ).json()
        wait_for_status(client, model["id"], ("ready",))
        stored_app.state.services.index.sync()  # ready in the database: in the index now too
        found = client.post("/v1/search", files={"file": ("b.xyz", second, "text/plain")})
        assert found.status_code == 200
        assert calls == [first]  # answered from the stored model
        best = found.json()["results"][0]
        assert best["model"]["id"] == model["id"] and best["score"] == 1.0
