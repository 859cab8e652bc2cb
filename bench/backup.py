"""What ``shapesearch backup`` costs, and whether the service's writes go on meanwhile.

Builds an embedded database of ``--models`` ready models, each with its stored file
(``--file-kb`` of incompressible bytes) and a descriptor, then, with a writer thread
committing one small update after another as the API does (the service's own engine: WAL,
busy timeout), measures

* the backup (``app.cli.backup.backup_sqlite``: ``VACUUM INTO``, the integrity check, the
  rename) against a plain file copy of the same database (``shutil.copyfile``: no
  consistency, the disk's own speed) in the same run, medians of ``--repeats``;
* the writer's commit latency while nothing else runs, and while each backup runs.

With ``--database-url`` (an empty PostgreSQL database) the backup is
``app.cli.backup.backup_postgres`` (an exported snapshot, ``pg_dump --format=custom``, the
archive read back) and the baseline a plain ``pg_dump --format=custom`` of the same
database.

    .venv/bin/python -m bench.backup --models 20000 --file-kb 40 --repeats 3
    .venv/bin/python -m bench.backup --database-url postgresql+psycopg://postgres@127.0.0.1/bench
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import subprocess
import tempfile
import threading
import time
import uuid
from pathlib import Path

import numpy as np
from sqlalchemy import insert, text
from sqlalchemy.engine import make_url

from app.cli.backup import backup_postgres, backup_sqlite
from app.db.migrate import upgrade
from app.db.models import Model, Upload, utcnow
from app.db.session import make_engine


def fill(url: str, models: int, file_bytes: int, chunk: int = 500) -> list[uuid.UUID]:
    engine = make_engine(url)
    upgrade(engine)
    rng = np.random.default_rng(0)
    ids: list[uuid.UUID] = []
    now = utcnow()
    for start in range(0, models, chunk):
        model_rows, upload_rows = [], []
        for _ in range(min(chunk, models - start)):
            model_id = uuid.uuid4()
            ids.append(model_id)
            model_rows.append({
                "id": model_id, "tenant": "default", "metadata": {}, "status": "ready",
                "file_name": "part.stl", "file_size": file_bytes, "file_sha256": "0" * 64,
                "file_format": "stl", "descriptor_version": "bench",
                "descriptor": rng.normal(size=1500).astype(np.float32).tobytes(),
                "created_at": now, "updated_at": now,
            })
            upload_rows.append({"model_id": model_id, "content": rng.bytes(file_bytes)})
        with engine.begin() as connection:
            connection.execute(insert(Model.__table__), model_rows)
            connection.execute(insert(Upload.__table__), upload_rows)
    engine.dispose()
    return ids


class Writer(threading.Thread):
    """Commits ``UPDATE models SET name`` on random models until stopped; records each
    commit's latency with the time it ended."""

    def __init__(self, url: str, ids: list[uuid.UUID]) -> None:
        super().__init__(daemon=True)
        self.engine = make_engine(url)
        self.ids = ids
        self.stop = threading.Event()
        self.commits: list[tuple[float, float]] = []  # (ended at, seconds)

    def run(self) -> None:
        rng = np.random.default_rng(1)
        while not self.stop.is_set():
            model_id = self.ids[int(rng.integers(len(self.ids)))]
            started = time.perf_counter()
            key = model_id.hex if self.engine.dialect.name == "sqlite" else model_id
            with self.engine.begin() as connection:
                connection.execute(text("UPDATE models SET name = :name WHERE id = :id"),
                                   {"name": f"n{started}", "id": key})
            ended = time.perf_counter()
            self.commits.append((ended, ended - started))
            time.sleep(0.002)
        self.engine.dispose()

    def between(self, start: float, end: float) -> list[float]:
        return [seconds for ended, seconds in self.commits if start <= ended <= end]


def latency(seconds: list[float]) -> str:
    if not seconds:
        return "no commits"
    ms = np.array(seconds) * 1e3
    return (f"{len(ms)} commits, median {np.median(ms):.2f} ms, p99 "
            f"{np.percentile(ms, 99):.2f} ms, max {ms.max():.1f} ms")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", type=int, default=20000)
    parser.add_argument("--file-kb", type=int, default=40)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--database-url", help="an empty PostgreSQL database (default: SQLite)")
    args = parser.parse_args()

    folder = Path(tempfile.mkdtemp(prefix="shapesearch-bench-backup-"))
    database = folder / "shapesearch.db"
    url = args.database_url or f"sqlite:///{database}"
    postgres = args.database_url is not None
    started = time.perf_counter()
    ids = fill(url, args.models, args.file_kb * 1024)
    size_mb = database_bytes(url) / 1e6
    print(f"{args.models} models with {args.file_kb} KB files: {size_mb:.0f} MB database, "
          f"filled in {time.perf_counter() - started:.0f} s; load {os.getloadavg()[0]:.1f}")

    writer = Writer(url, ids)
    writer.start()
    time.sleep(3.0)
    idle = writer.between(0.0, time.perf_counter())
    copies, backups, during = [], [], []
    for repeat in range(args.repeats):
        plain = folder / f"plain-{repeat}"
        start = time.perf_counter()
        if postgres:
            libpq = make_url(url).set(drivername="postgresql").render_as_string(False)
            subprocess.run(["pg_dump", "--format=custom", f"--file={plain}", f"--dbname={libpq}"],
                           check=True)
        else:
            shutil.copyfile(database, plain)
        copies.append(time.perf_counter() - start)
        start = time.perf_counter()
        target = folder / f"backup-{repeat}"
        made = backup_postgres(make_url(url), target) if postgres else backup_sqlite(
            database, target)
        end = time.perf_counter()
        backups.append(end - start)
        during.extend(writer.between(start, end))
        assert made.models_by_status == {"ready": args.models}, made.models_by_status
        plain.unlink()
        made.path.unlink()
        time.sleep(1.0)
    writer.stop.set()
    writer.join()

    copy, backup = statistics.median(copies), statistics.median(backups)
    baseline = "plain pg_dump (baseline)" if postgres else "plain file copy (baseline)"
    print(f"{baseline}: median {copy:.2f} s ({size_mb / copy:.0f} MB/s)")
    print(f"shapesearch backup: median {backup:.2f} s ({size_mb / backup:.0f} MB/s), "
          f"{backup / copy:.1f}x the baseline")
    print(f"writer alone:          {latency(idle)}")
    print(f"writer during backups: {latency(during)}")
    shutil.rmtree(folder)


def database_bytes(url: str) -> int:
    engine = make_engine(url)
    try:
        with engine.connect() as connection:
            if engine.dialect.name == "sqlite":
                pages = connection.execute(text("PRAGMA page_count")).scalar_one()
                return int(pages) * int(connection.execute(text("PRAGMA page_size")).scalar_one())
            size = connection.execute(text("SELECT pg_database_size(current_database())"))
            return int(size.scalar_one())
    finally:
        engine.dispose()


if __name__ == "__main__":
    main()
