"""Benchmark: the default request path against the framework's floor, with wrk (issue 22).

Starts ``shapesearch serve`` with no settings but a temporary data directory and a free port
(embedded SQLite, embedded worker), stores ``--models`` small parts made in code, then drives
three routes with `wrk <https://github.com/wg/wrk>`_ (Debian package ``wrk``), one after the
other, on the same server in the same run:

- ``GET /healthz``: FastAPI and uvicorn with no work of ours, the floor;
- ``GET /v1/models/{id}/similar?k=10``: a search by a stored part (one id per request, cycled);
- ``GET /v1/models?limit=10``: a catalogue page.

It prints requests per second, p50 and p99 latency per route and the ratio of each route's rate
to ``/healthz``'s (target: >= 0.5x). Absolute figures differ ~3x between machines; the ratios
are measured in one run on one machine and travel better.

Usage::

    .venv/bin/python -m bench.request_path [--models 40] [--connections 16] [--seconds 10]
    SHAPESEARCH_API_PROCESSES=2 .venv/bin/python -m bench.request_path   # any setting passes
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile

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


def store_parts(base: str, count: int) -> list[str]:
    """Upload ``count`` parts and wait until every one is described."""
    ids = []
    for seed in range(count):
        answer = httpx.post(f"{base}/v1/models", files={"file": (f"part{seed}.stl", part(seed))})
        answer.raise_for_status()
        ids.append(answer.json()["id"])
    wait_until(
        lambda: all(
            httpx.get(f"{base}/v1/models/{model_id}").json()["status"] in ("ready", "failed")
            for model_id in ids
        ),
        600,
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
        output = subprocess.run(command, capture_output=True, text=True, check=True).stdout
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


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", type=int, default=40)
    parser.add_argument("--connections", type=int, default=16)
    parser.add_argument("--seconds", type=int, default=10)
    parser.add_argument("--rounds", type=int, default=2, help="each route this many times")
    args = parser.parse_args()
    if shutil.which("wrk") is None:
        print("error: wrk is not installed (apt-get install wrk)", file=sys.stderr)
        return 2
    env = {"SHAPESEARCH_DATA_DIR": tempfile.mkdtemp(), "SHAPESEARCH_LOG_LEVEL": "warning"}
    with shapesearch(env=env) as base:
        ids = store_parts(base, args.models)
        quoted = ", ".join(f'"/v1/models/{model_id}/similar?k=10"' for model_id in ids)
        routes = {
            "/healthz": (f"{base}/healthz", None),
            "similar?k=10": (base, CYCLE_IDS % quoted),
            "models?limit=10": (f"{base}/v1/models?limit=10", None),
        }
        results: dict[str, list[dict[str, float]]] = {name: [] for name in routes}
        for _ in range(args.rounds):  # interleaved, so that a noisy minute hits every route
            for name, (url, script) in routes.items():
                results[name].append(wrk(url, args.connections, args.seconds, script))
        floor = max(run["rate"] for run in results["/healthz"])
        print(f"{args.models} models, wrk c={args.connections}, {args.seconds} s x "
              f"{args.rounds} rounds, {os.cpu_count()} cores, load average "
              f"{os.getloadavg()[0]:.1f}; settings: "
              + (" ".join(f"{k}={v}" for k, v in os.environ.items()
                          if k.startswith("SHAPESEARCH_")) or "none"))
        for name, runs in results.items():
            best = max(runs, key=lambda run: run["rate"])
            print(f"{name:>16}: {best['rate']:8.0f} req/s  p50 {best['p50']:6.1f} ms  "
                  f"p99 {best['p99']:6.1f} ms  errors {best['errors']:.0f}  "
                  f"{best['rate'] / floor:.2f}x /healthz")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
