"""Peak memory of ``shapesearch import``: 20 files against 2,000, from a folder, a .zip and a
.tar.gz.

Generates small, varied meshes (trimesh primitives of random sizes, binary STL and PLY,
a few KB each) in a temporary folder, packs the 2,000-file catalogue also as a .zip and a
.tar.gz, and runs the importer as a child process (``python -m app.cli import``) against a
stub HTTP server in this process: it answers ``GET /v1/models`` with an empty page and
every ``PUT /v1/models/by-external-id/...`` with 201, like the API for a new external id.
The importer is the subject, not the service: the stub keeps the run fast and its memory
out of the figure. Each child's peak resident memory comes from GNU ``/usr/bin/time``
(``%M``, its own ``ru_maxrss``). Baselines in the same run: an empty folder (the interpreter and the
importer's imports) and 20 files; streaming holds at most 2 x concurrency files at a time,
so 2,000 files should cost about what 20 cost. Control: 500 files of ~250 KiB (122 MiB in
all) must not add their size either (an importer that read the catalogue first would).

    nice -n 10 .venv/bin/python -m bench.import_memory [--files 2000] [--heavy 500]
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import random
import subprocess
import sys
import tarfile
import tempfile
import threading
import time
import zipfile
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path

import trimesh

ROOT = Path(__file__).resolve().parents[1]

PRIMITIVES: list[Callable[[random.Random], trimesh.Trimesh]] = [
    lambda r: trimesh.creation.box(extents=[r.uniform(1, 50) for _ in range(3)]),
    lambda r: trimesh.creation.cylinder(radius=r.uniform(1, 20), height=r.uniform(1, 80),
                                        sections=r.randint(8, 24)),
    lambda r: trimesh.creation.capsule(height=r.uniform(1, 40), radius=r.uniform(1, 10),
                                       count=[r.randint(6, 12), r.randint(6, 12)]),
    lambda r: trimesh.creation.icosphere(subdivisions=1, radius=r.uniform(1, 30)),
    lambda r: trimesh.creation.cone(radius=r.uniform(1, 20), height=r.uniform(1, 40),
                                    sections=r.randint(8, 24)),
    lambda r: trimesh.creation.annulus(r_min=r.uniform(1, 5), r_max=r.uniform(6, 20),
                                       height=r.uniform(1, 10), sections=r.randint(8, 24)),
]


def make_catalogue(folder: Path, count: int, seed: int = 0, heavy: bool = False) -> int:
    """``count`` small meshes in ``folder`` (10 sub-folders); returns their total bytes.
    ``heavy``: finely tessellated spheres of ~250 KiB instead (20,480 triangles in STL)."""
    rng = random.Random(seed)
    total = 0
    for i in range(count):
        if heavy:
            mesh = trimesh.creation.icosphere(subdivisions=4, radius=rng.uniform(1, 30))
        else:
            mesh = PRIMITIVES[i % len(PRIMITIVES)](rng)
        mesh.apply_scale(rng.uniform(0.5, 2.0))
        kind = "stl" if i % 3 else "ply"
        path = folder / f"family-{i % 10}" / f"part-{i:05d}.{kind}"
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(bytes(mesh.export(file_type=kind)))
        total += path.stat().st_size
    return total


def pack(folder: Path, zip_path: Path, tar_path: Path) -> None:
    files = sorted(p for p in folder.rglob("*") if p.is_file())
    with zipfile.ZipFile(zip_path, "w", zipfile.ZIP_DEFLATED) as zipped:
        for file in files:
            zipped.write(file, file.relative_to(folder).as_posix())
    with tarfile.open(tar_path, "w:gz") as tarred:
        for file in files:
            tarred.add(file, file.relative_to(folder).as_posix())


class StubApi(BaseHTTPRequestHandler):
    """Just enough of the API for the importer: an empty model list, 201 for every PUT."""

    protocol_version = "HTTP/1.1"  # keep-alive, like uvicorn
    disable_nagle_algorithm = True  # headers and body go out at once (no 40 ms delayed ACK)
    uploads = 0
    lock = threading.Lock()

    def _answer(self, status: int, body: dict[str, object]) -> None:
        data = json.dumps(body).encode()
        self.send_response(status)
        self.send_header("content-type", "application/json")
        self.send_header("content-length", str(len(data)))
        self.end_headers()
        self.wfile.write(data)

    def do_GET(self) -> None:  # noqa: N802 (http.server's naming)
        self._answer(200, {"items": [], "next_cursor": None})

    def do_PUT(self) -> None:  # noqa: N802
        length = int(self.headers.get("content-length", "0"))
        self.rfile.read(length)  # the multipart body, dropped
        with StubApi.lock:
            StubApi.uploads += 1
            number = StubApi.uploads
        self._answer(201, {"id": f"00000000-0000-0000-0000-{number:012d}"})

    def log_message(self, *args: object) -> None:
        pass


@contextmanager
def stub_server() -> Iterator[str]:
    server = ThreadingHTTPServer(("127.0.0.1", 0), StubApi)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{server.server_address[1]}"
    finally:
        server.shutdown()
        server.server_close()


def run_importer(source: Path, url: str, report: Path, concurrency: int) -> tuple[float, int]:
    """Seconds and peak resident bytes of one ``shapesearch import`` child process.

    Through GNU time (``%M``): Linux carries the resident high-water mark of the process that
    forks across ``exec``, so a child started from this process (trimesh, the meshes) would
    report at least this process's size; time is a small C program.
    """
    env = {**os.environ, "PYTHONPATH": str(ROOT), "SHAPESEARCH_URL": url}
    peak_file = report.with_suffix(".peak")
    command = ["/usr/bin/time", "-f", "%M", "-o", str(peak_file),
               sys.executable, "-m", "app.cli", "import", str(source), "--report", str(report),
               "--concurrency", str(concurrency)]
    started = time.perf_counter()
    code = subprocess.call(command, env=env, cwd=ROOT, stdout=subprocess.DEVNULL,
                           stderr=subprocess.DEVNULL)
    seconds = time.perf_counter() - started
    if code != 0:
        raise SystemExit(f"the importer exited with {code} on {source}")
    return seconds, int(peak_file.read_text().split()[-1]) * 1024  # KiB


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--files", type=int, default=2000)
    parser.add_argument("--small", type=int, default=20, help="files of the baseline run")
    parser.add_argument("--heavy", type=int, default=500,
                        help="files of the ~250 KiB control run (0: none)")
    parser.add_argument("--concurrency", type=int, default=4)
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as temp, stub_server() as url:
        work = Path(temp)
        (work / "empty").mkdir()
        small_bytes = make_catalogue(work / "small", args.small)
        large_bytes = make_catalogue(work / "large", args.files, seed=1)
        heavy_bytes = make_catalogue(work / "heavy", args.heavy, seed=2, heavy=True)
        pack(work / "large", work / "large.zip", work / "large.tar.gz")
        cases = [
            ("empty folder", work / "empty", 0, 0),
            (f"{args.small} files, folder", work / "small", args.small, small_bytes),
            (f"{args.files} files, folder", work / "large", args.files, large_bytes),
            (f"{args.files} files, .zip", work / "large.zip", args.files, large_bytes),
            (f"{args.files} files, .tar.gz", work / "large.tar.gz", args.files, large_bytes),
        ]
        if args.heavy:
            cases.append((f"{args.heavy} heavy, folder", work / "heavy", args.heavy, heavy_bytes))
        print(f"importer against a stub API, --concurrency {args.concurrency}; "
              f"mean file {large_bytes / args.files / 1024:.1f} KiB")
        print(f"{'catalogue':24} {'MiB of files':>12} {'peak RSS MiB':>12} {'vs small':>9} "
              f"{'seconds':>8} {'files/s':>8}")
        small_peak = 0
        for name, source, count, size in cases:
            report = work / "report.csv"
            StubApi.uploads = 0
            seconds, peak = run_importer(source, url, report, args.concurrency)
            with report.open(newline="") as handle:
                rows = list(csv.DictReader(handle))
            assert len(rows) == count == StubApi.uploads, (name, len(rows), StubApi.uploads)
            assert all(row["outcome"] == "accepted" for row in rows), name
            if count == args.small:
                small_peak = peak
            ratio = f"{peak / small_peak:.2f}x" if small_peak else ""
            print(f"{name:24} {size / 2**20:>12.1f} {peak / 2**20:>12.1f} {ratio:>9} "
                  f"{seconds:>8.2f} {count / seconds:>8.0f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
