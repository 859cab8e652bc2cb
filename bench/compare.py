"""Benchmark: ``GET /v1/models/{id}/compare/{other_id}`` of two ready 3000-point parts, through
a real ``shapesearch serve``, against ``/healthz`` and a similar-parts query in the same run.

Starts the service on a temporary data directory and a free port (embedded SQLite, embedded
worker, default engine: 3000 points a part), stores the pairs below (a part and a turned copy
with one end 10 % longer, two different parts, a part and a turned copy), then, round by
round, asks each pair's comparison with a tolerance of its own (the cache keys on it, so
every answer is computed; the tolerance changes no work) and, between them, ``/healthz`` and
``/v1/models/{id}/similar?k=5``. Prints the medians, the comparison's core alone (the same
points compared in this process by ``core.compare``), a cached answer, and the machine's
load before and after. Target: a comparison in at most 0.3 s (median).

Usage::

    .venv/bin/python -m bench.compare [--rounds 7]
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time

import httpx
import numpy as np
import trimesh

from bench._common import PARTS, shapesearch, wait_until

TARGET_SECONDS = 0.3


def _turned(name: str, stretch: float = 0.0) -> bytes:
    """The part ``name`` turned by a fixed rotation, with the half beyond the middle of its
    longest extent stretched so that its end moves by ``stretch`` of the length."""
    mesh = trimesh.load(PARTS / name, file_type="stl")
    vertices = np.asarray(mesh.vertices).copy()
    axis = int(np.argmax(np.ptp(vertices, axis=0)))
    low, high = vertices[:, axis].min(), vertices[:, axis].max()
    weight = np.clip((vertices[:, axis] - (low + high) / 2) / ((high - low) / 2), 0.0, None)
    vertices[:, axis] += weight * stretch * (high - low)
    rotation = np.linalg.qr(np.random.default_rng(5).normal(size=(3, 3)))[0]
    if np.linalg.det(rotation) < 0:
        rotation[:, 0] = -rotation[:, 0]
    mesh.vertices = vertices @ rotation.T + [3.0, -1.0, 2.0]
    return bytes(mesh.export(file_type="stl"))


PAIRS = (
    (("featuretype.STL", None), ("featuretype-long.STL", lambda: _turned("featuretype.STL", 0.1))),
    (("angle_block.STL", None), ("featuretype.STL", None)),
    (("teapot.stl", None), ("teapot-turned.stl", lambda: _turned("teapot.stl"))),
)


def _median_ms(values: list[float]) -> str:
    return f"{1000 * statistics.median(values):.1f} ms"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=7)
    args = parser.parse_args()
    load_before = os.getloadavg()
    contents = {}
    for pair in PAIRS:
        for name, make in pair:
            contents[name] = make() if make else (PARTS / name).read_bytes()
    with shapesearch(env={"SHAPESEARCH_DATA_DIR": tempfile.mkdtemp()}) as base, \
            httpx.Client(base_url=base, timeout=120) as client:
        ids = {}
        for name, content in contents.items():
            response = client.post("/v1/models", files={"file": (name, content)},
                                   data={"name": name})
            ids[name] = response.json()["id"]
        for model_id in ids.values():
            wait_until(lambda m=model_id: client.get(f"/v1/models/{m}").json()["status"]
                       in ("ready", "failed"), 600)
        points = {name: client.get(f"/v1/models/{m}").json()["n_points"]
                  for name, m in ids.items()}
        print("points per part:", points)
        compare: list[float] = []
        health: list[float] = []
        similar: list[float] = []
        first = ids[PAIRS[0][0][0]]
        for round_number in range(args.rounds):
            for (a, _), (b, _) in PAIRS:
                tolerance = 0.05 * (1.0 + 1e-6 * round_number)  # a new cache key each round
                start = time.perf_counter()
                response = client.get(f"/v1/models/{ids[a]}/compare/{ids[b]}",
                                      params={"tolerance": tolerance})
                compare.append(time.perf_counter() - start)
                assert response.status_code == 200, response.text
                start = time.perf_counter()
                assert client.get("/healthz").status_code == 200
                health.append(time.perf_counter() - start)
                start = time.perf_counter()
                assert client.get(f"/v1/models/{first}/similar", params={"k": 5}).is_success
                similar.append(time.perf_counter() - start)
        start = time.perf_counter()
        client.get(f"/v1/models/{ids[PAIRS[0][0][0]]}/compare/{ids[PAIRS[0][1][0]]}",
                   params={"tolerance": 0.05})
        cached = time.perf_counter() - start
        for (a, _), (b, _) in PAIRS:
            answer = client.get(f"/v1/models/{ids[a]}/compare/{ids[b]}").json()
            print(f"  {a} <- {b}: RMS {answer['model_to_other']['rms']:.4g} / "
                  f"{answer['other_to_model']['rms']:.4g}, max "
                  f"{answer['other_to_model']['max']:.4g}, within "
                  f"{answer['model_to_other']['within']:.3f} / "
                  f"{answer['other_to_model']['within']:.3f}, starts "
                  f"{answer['alignment']['candidates']}")
    core = _core_seconds(contents, args.rounds)
    load_after = os.getloadavg()
    median = statistics.median(compare)
    print(f"compare (end to end, computed): median {_median_ms(compare)} over {len(compare)} "
          f"(min {1000 * min(compare):.1f}, max {1000 * max(compare):.1f}); "
          f"{median / statistics.median(health):.0f}x /healthz ({_median_ms(health)}), "
          f"{median / statistics.median(similar):.1f}x similar k=5 ({_median_ms(similar)})")
    print(f"compare, cached answer: {1000 * cached:.1f} ms; core.compare alone, in process: "
          f"median {_median_ms(core)}")
    print(f"load average before {load_before[0]:.2f}, after {load_after[0]:.2f}; "
          f"{os.cpu_count()} cores")
    print(f"target <= {TARGET_SECONDS} s: {'met' if median <= TARGET_SECONDS else 'NOT met'}")
    return 0


def _core_seconds(contents: dict[str, bytes], rounds: int) -> list[float]:
    """``core.compare`` of each pair's points as the service stores them (the same
    sampling), in this process: the comparison without the HTTP, database and JSON."""
    from core.compare import compare
    from core.io import load_points
    from core.settings import EngineSettings

    engine = EngineSettings()
    points = {name: load_points(content, filename=name, max_points=engine.max_points,
                                seed=engine.sample_seed).points
              for name, content in contents.items()}
    seconds = []
    for _ in range(rounds):
        for (a, _), (b, _) in PAIRS:
            start = time.perf_counter()
            compare(points[a], points[b], tolerance=0.05)
            seconds.append(time.perf_counter() - start)
    return seconds


if __name__ == "__main__":
    raise SystemExit(main())
