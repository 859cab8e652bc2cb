"""Benchmark: the default request path against the framework's floor, with wrk (issues 22, 78).

Starts ``shapesearch serve`` with no settings but a temporary data directory and a free port
(embedded SQLite, embedded worker), stores ``--models`` parts (small parts made in code, or
the mesh files under ``--parts``, taken in turn from its subdirectories), then measures the
same routes twice, each time on its own server over the same data, in the same run:

* **as served** (the default settings, repeated requests: what the one-second response cache
  serves to clients that ask again): ``GET /healthz``, the floor (FastAPI and uvicorn with no
  work of ours); ``GET /v1/models/{id}/similar?k=10``, one stored id per request in turn;
  ``GET /v1/models?limit=10``;
* **cache off, distinct requests** (``SHAPESEARCH_RESPONSE_CACHE_SECONDS=0``, and every
  request unlike the last: ``k`` 5..15 with the ids in turn, ``limit`` 5..15): what a request
  costs when nothing is served from memory.

Each route runs ``--rounds`` times, interleaved (so that a noisy minute hits every route), and
its best round is printed: requests per second, p50 and p99 latency, and the ratio of its rate
to the same server's ``/healthz`` (targets: >= 0.5x as served, >= 0.3x with the cache off).
Absolute figures differ ~3x between machines; the ratios are measured in one run on one
machine and travel better.

Usage::

    .venv/bin/python -m bench.request_path [--models 40] [--parts DIR] [--connections 16]
        [--seconds 10] [--rounds 2]
    .venv/bin/python -m bench.request_path --parts /work/shared/datasets/capod
    SHAPESEARCH_API_PROCESSES=2 .venv/bin/python -m bench.request_path   # any setting passes
"""

from __future__ import annotations

import argparse
import itertools
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import httpx
import numpy as np
import trimesh

from bench._common import shapesearch, wait_until

# wrk runs one Lua script per connection: each request takes the next id of the list.
CYCLE_IDS = """
local ids = {%s}
local i = 0
request = function()
  i = i + 1
  return wrk.format("GET", ids[(i %% #ids) + 1])
end
"""
# Every request unlike the last: the next id, and k 5..15 (11 and the 40 ids share no factor).
DISTINCT_SIMILAR = """
local ids = {%s}
local i = 0
request = function()
  i = i + 1
  return wrk.format("GET", ids[(i %% #ids) + 1] .. "?k=" .. (5 + (i * 7) %% 11))
end
"""
DISTINCT_PAGES = """
local i = 0
request = function()
  i = i + 1
  return wrk.format("GET", "/v1/models?limit=" .. (5 + i % 11))
end
"""


def part(seed: int) -> bytes:
    """A small box, cylinder or capsule of random proportions, as binary STL."""
    rng = np.random.default_rng(seed)
    kind = seed % 3
    if kind == 0:
        mesh = trimesh.creation.box(extents=rng.uniform(1.0, 4.0, size=3))
    elif kind == 1:
        mesh = trimesh.creation.cylinder(radius=rng.uniform(0.5, 2), height=rng.uniform(1, 5))
    else:
        mesh = trimesh.creation.capsule(height=rng.uniform(1, 4), radius=rng.uniform(0.3, 1))
    return mesh.export(file_type="stl")


def mesh_files(root: Path, count: int) -> list[Path]:
    """``count`` mesh files under ``root``: the first file of each subdirectory (sorted),
    then the second of each, and so on (``root``'s own files when it has no subdirectory)."""
    folders = sorted(p for p in root.iterdir() if p.is_dir()) or [root]
    files = [sorted(f for f in folder.iterdir() if f.is_file() and f.suffix.lower() in
                    (".stl", ".obj", ".ply", ".off")) for folder in folders]
    chosen = [f for row in itertools.zip_longest(*files) for f in row if f is not None]
    if len(chosen) < count:
        raise SystemExit(f"error: {root} holds {len(chosen)} mesh files, fewer than {count}")
    return chosen[:count]


def store_parts(base: str, count: int, root: Path | None = None) -> list[str]:
    """Upload ``count`` parts (made in code, or the files of ``mesh_files(root)``) and wait
    until every one is described."""
    uploads = ([(path.name, path.read_bytes()) for path in mesh_files(root, count)] if root
               else [(f"part{seed}.stl", part(seed)) for seed in range(count)])
    ids = []
    for name, content in uploads:
        answer = httpx.post(f"{base}/v1/models", files={"file": (name, content)}, timeout=60)
        answer.raise_for_status()
        ids.append(answer.json()["id"])
    wait_until(
        lambda: all(
            httpx.get(f"{base}/v1/models/{model_id}").json()["status"] in ("ready", "failed")
            for model_id in ids
        ),
        1800,
    )
    return ids


def wrk(url: str, connections: int, seconds: int, script: str | None = None) -> dict[str, float]:
    """One wrk run: requests per second, p50 and p99 in milliseconds, non-2xx answers."""
    command = ["wrk", f"-t{min(connections, 2)}", f"-c{connections}", f"-d{seconds}s",
               "--latency", url]
    with tempfile.NamedTemporaryFile("w", suffix=".lua") as lua:
        if script:
            lua.write(script)
            lua.flush()
            command[1:1] = ["-s", lua.name]
        done = subprocess.run(command, capture_output=True, text=True, check=True)
    if done.stderr.strip():  # a script wrk could not load: it would measure the bare URL
        raise RuntimeError(f"wrk: {done.stderr.strip()}")
    output = done.stdout
    rate = float(re.search(r"Requests/sec:\s+([\d.]+)", output).group(1))  # type: ignore[union-attr]
    errors = re.search(r"Non-2xx or 3xx responses: (\d+)", output)
    return {
        "rate": rate,
        "p50": _milliseconds(re.search(r"50%\s+([\d.]+\w+)", output).group(1)),  # type: ignore[union-attr]
        "p99": _milliseconds(re.search(r"99%\s+([\d.]+\w+)", output).group(1)),  # type: ignore[union-attr]
        "errors": float(errors.group(1)) if errors else 0.0,
    }


def _milliseconds(text: str) -> float:
    value, unit = re.fullmatch(r"([\d.]+)(\w+)", text).groups()  # type: ignore[union-attr]
    return float(value) * {"us": 1e-3, "ms": 1.0, "s": 1e3, "m": 6e4}[unit]


def measure(base: str, routes: dict[str, tuple[str, str | None]], args: argparse.Namespace
            ) -> dict[str, dict[str, float]]:
    """Each route's best of ``args.rounds`` wrk runs, the rounds interleaved (so that a noisy
    minute hits every route), with its ratio to the best ``/healthz`` rate."""
    results: dict[str, list[dict[str, float]]] = {name: [] for name in routes}
    for _ in range(args.rounds):
        for name, (path, script) in routes.items():
            results[name].append(wrk(base + path, args.connections, args.seconds, script))
    floor = max(run["rate"] for run in results["/healthz"])
    best = {name: max(runs, key=lambda run: run["rate"]) for name, runs in results.items()}
    for run in best.values():
        run["ratio"] = run["rate"] / floor
    return best


def report(title: str, best: dict[str, dict[str, float]]) -> None:
    print(f"{title} (load average {os.getloadavg()[0]:.1f} at the end):")
    for name, run in best.items():
        print(f"  {name:>28}: {run['rate']:8.0f} req/s  p50 {run['p50']:6.1f} ms  "
              f"p99 {run['p99']:6.1f} ms  errors {run['errors']:.0f}  "
              f"{run['ratio']:.2f}x /healthz")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", type=int, default=40)
    parser.add_argument("--parts", type=Path, help="mesh files to store instead of made parts")
    parser.add_argument("--connections", type=int, default=16)
    parser.add_argument("--seconds", type=int, default=10)
    parser.add_argument("--rounds", type=int, default=2, help="each route this many times")
    args = parser.parse_args()
    if shutil.which("wrk") is None:
        print("error: wrk is not installed (apt-get install wrk)", file=sys.stderr)
        return 2
    data = tempfile.mkdtemp()
    started = os.getloadavg()[0]
    with shapesearch(env={"SHAPESEARCH_DATA_DIR": data}) as base:
        ids = store_parts(base, args.models, args.parts)
        print(f"{args.models} models stored ({args.parts or 'made parts'}), wrk "
              f"c={args.connections}, {args.seconds} s x {args.rounds} rounds, "
              f"{os.cpu_count()} cores, load average {started:.1f} at the start; settings: "
              + (" ".join(f"{k}={v}" for k, v in os.environ.items()
                          if k.startswith("SHAPESEARCH_")) or "none"))
        served = measure(base, {
            "/healthz": ("/healthz", None),
            "similar?k=10": ("", CYCLE_IDS % ", ".join(
                f'"/v1/models/{model_id}/similar?k=10"' for model_id in ids)),
            "models?limit=10": ("/v1/models?limit=10", None),
        }, args)
    report("as served (repeated requests)", served)
    # The same data on a server without the response cache, every request unlike the last.
    cache_off = {"SHAPESEARCH_DATA_DIR": data, "SHAPESEARCH_RESPONSE_CACHE_SECONDS": "0"}
    with shapesearch(env=cache_off) as base:
        uncached = measure(base, {
            "/healthz": ("/healthz", None),
            "similar?k=5..15": ("", DISTINCT_SIMILAR % ", ".join(
                f'"/v1/models/{model_id}/similar"' for model_id in ids)),
            "models?limit=5..15": ("", DISTINCT_PAGES),
        }, args)
    report("cache off, distinct requests", uncached)
    shutil.rmtree(data, ignore_errors=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
