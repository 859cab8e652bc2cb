"""What a flood of files that hang their reader costs the API: answer time, children, health.

Starts ``shapesearch serve --no-worker`` on an empty SQLite database and posts ``--uploads``
copies of an IGES file on which OpenCascade's reader never returns
(``tests/hostile_files.iges_reader_hang``) to ``/v1/models`` at once. Prints the median and
largest time until each upload is answered, their statuses, the most quick-check children
the server had alive at one time (sampled from /proc), and the median /healthz latency
during the flood against the same server idle (the baseline, measured in the same run).

Run it twice to compare: with the defaults (``SHAPESEARCH_UPLOAD_CHECK_MAX_CONCURRENT`` 2,
``SHAPESEARCH_UPLOAD_CHECK_TIMEOUT_SECONDS`` 10) and with ``--unbounded``, which gives every
upload a slot and the describe's time limit (what the service did before the checks were
bounded, but for the status: those uploads got 413 at the limit, where they now get 202; the
describe limit is lowered to ``--describe-seconds``, 300 s by default in the service, so
that the run ends).

    nice -n 10 .venv/bin/python -m bench.upload_checks [--uploads 6] [--unbounded]

Needs OpenCascade (the ``cad`` extra) and Linux's /proc.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import httpx

from tests.hostile_files import iges_reader_hang, opencascade_imports, step_part
from tests.servers import running_server


def descendants(pid: int) -> set[int]:
    """Every process below ``pid``, from /proc."""
    parents: dict[int, int] = {}
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        parents[int(stat.parent.name)] = int(fields[1])
    found, frontier = set(), {pid}
    while frontier:
        frontier = {child for child, parent in parents.items() if parent in frontier}
        found |= frontier
    return found


def health_latencies(client: httpx.Client, seconds: float) -> list[float]:
    latencies, deadline = [], time.monotonic() + seconds
    while time.monotonic() < deadline:
        started = time.perf_counter()
        client.get("/healthz")
        latencies.append(time.perf_counter() - started)
        time.sleep(0.05)
    return latencies


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--uploads", type=int, default=6)
    parser.add_argument("--unbounded", action="store_true")
    parser.add_argument("--describe-seconds", type=float, default=30.0)
    args = parser.parse_args()
    if not opencascade_imports():
        print("OpenCascade (the cad extra) does not import here")
        return 1
    settings: dict[str, object] = {}
    if args.unbounded:
        settings = {"upload_check_max_concurrent": args.uploads,
                    "upload_check_timeout_seconds": args.describe_seconds,
                    "describe_timeout_seconds": args.describe_seconds}
    content = iges_reader_hang()
    with (
        tempfile.TemporaryDirectory() as data,
        running_server(Path(data), **settings) as (base, pid),
        httpx.Client(base_url=base, timeout=600) as client,
    ):
        # A valid part first: its check starts the sandbox's forkserver and multiprocessing's
        # resource tracker, which are no check's children.
        warm_up = client.post("/v1/models", files={"file": ("part.step", step_part())})
        assert warm_up.status_code == 202, warm_up.text
        at_rest = descendants(pid)
        idle = health_latencies(client, 3.0)

        def post(_: int) -> tuple[float, int]:
            started = time.perf_counter()
            response = httpx.post(base + "/v1/models", timeout=600,
                                  files={"file": ("part.iges", content)})
            return time.perf_counter() - started, response.status_code

        peak, done = 0, threading.Event()

        def watch() -> None:
            nonlocal peak
            while not done.is_set():
                peak = max(peak, len(descendants(pid) - at_rest))
                time.sleep(0.1)

        watcher = threading.Thread(target=watch, daemon=True)
        watcher.start()
        with ThreadPoolExecutor(args.uploads + 1) as pool:
            uploads = pool.map(post, range(args.uploads))
            busy = pool.submit(health_latencies, client, 5.0)
            answers = list(uploads)
            flooded = busy.result()
        done.set()
        watcher.join()
    seconds = [s for s, _ in answers]
    mode = "unbounded (a slot each, the describe limit)" if args.unbounded else "defaults"
    print(f"{args.uploads} hanging IGES uploads at once, {mode}")
    print(f"answered: median {statistics.median(seconds):.2f} s, largest {max(seconds):.2f} s; "
          f"statuses {sorted(status for _, status in answers)}")
    print(f"quick-check children alive at once: at most {peak}")
    print(f"/healthz median: idle {statistics.median(idle) * 1e3:.1f} ms, during the flood "
          f"{statistics.median(flooded) * 1e3:.1f} ms "
          f"({statistics.median(flooded) / statistics.median(idle):.1f}x)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
