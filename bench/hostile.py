"""Time to refuse each hostile file, end to end against a running server.

Starts ``shapesearch serve --no-worker`` on an empty SQLite database, posts each hostile file
of tests/hostile_files.py ``--repeats`` times to /v1/models and /v1/search, and prints the
median seconds until the refusal arrives (target: < 2 s each), its status, and the server's
peak resident memory. Baseline in the same run: the same requests with a small valid part
(and a small valid STEP part where OpenCascade imports).

    nice -n 10 .venv/bin/python -m bench.hostile [--repeats 3]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

import httpx

from bench._common import PARTS
from tests.hostile_files import HOSTILE_FILES, opencascade_imports, step_part
from tests.servers import peak_memory_bytes, running_server

CUBE = PARTS / "20mm-xyz-cube.stl"


def timed_post(client: httpx.Client, route: str, name: str, content: bytes) -> tuple[float, int]:
    started = time.perf_counter()
    response = client.post(route, files={"file": (name, content, "application/octet-stream")})
    return time.perf_counter() - started, response.status_code


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    cases = {"baseline-cube": ("cube.stl", CUBE.read_bytes)}
    if opencascade_imports():  # a valid CAD part: its check runs in the sandbox too
        cases["baseline-step"] = ("part.step", step_part)
    cases.update({name: (filename, make) for name, (filename, make, _, _) in HOSTILE_FILES.items()})
    with (
        tempfile.TemporaryDirectory() as data,
        running_server(Path(data)) as (base, pid),
        httpx.Client(base_url=base, timeout=600) as client,
    ):
        print(f"{'file':24} {'route':12} {'bytes':>10} {'status':>6} {'median s':>9} {'max s':>7}")
        for name, (filename, make) in cases.items():
            content = make()
            for route in ("/v1/models", "/v1/search"):
                runs = [timed_post(client, route, filename, content) for _ in range(args.repeats)]
                seconds = [s for s, _ in runs]
                print(
                    f"{name:24} {route:12} {len(content):>10} {runs[0][1]:>6} "
                    f"{statistics.median(seconds):>9.3f} {max(seconds):>7.3f}"
                )
        print(f"server peak resident memory: {peak_memory_bytes(pid) / 2**20:.0f} MiB")
    return 0


if __name__ == "__main__":
    sys.exit(main())
