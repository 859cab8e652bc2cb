"""``shapesearch backup DEST``: a consistent copy of the embedded SQLite database, taken
while the service runs.

Everything the service keeps (models, their stored files and revisions, descriptors, jobs,
API keys, webhooks, duplicates reports) lives in that one database, and the search index is
rebuilt from it at start-up, so the copy is the whole backup. SQLite's ``VACUUM INTO``
writes it from one read transaction on a read-only connection: the service's writers go on
(WAL), the copy holds what was committed when it began, compacted, with no ``-wal`` file
beside it. It is written next to DEST under a hidden name and renamed into place only after
``PRAGMA integrity_check`` passed, so DEST is never a half-written file.

On PostgreSQL the server's own tools do this (``pg_dump --format=custom``); the command
says so and stops.
"""

from __future__ import annotations

import sqlite3
import sys
import time
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path

from sqlalchemy.engine import make_url

from app.settings import Settings

__all__ = ["BackupError", "Backup", "backup_sqlite", "run"]


class BackupError(Exception):
    """The backup could not be made; the message says why (nothing was left at DEST)."""


@dataclass(frozen=True)
class Backup:
    """A finished backup: where, how large, and what it holds."""

    path: Path
    size_bytes: int
    models_by_status: dict[str, int]
    seconds: float


def run(destination: Path) -> int:
    """Back up the configured database to ``destination`` (a file, or a directory for a
    time-stamped file in it); exit code 2 on PostgreSQL or a refused destination."""
    url = make_url(Settings().resolved_database_url)
    if url.get_backend_name() != "sqlite":
        print(
            "error: the database is PostgreSQL; back it up with its own tools, e.g. "
            f"pg_dump --format=custom --host {url.host or 'HOST'} --username "
            f"{url.username or 'USER'} --file shapesearch.dump {url.database or 'DATABASE'}",
            file=sys.stderr,
        )
        return 2
    source = Path(url.database or "")
    try:
        made = backup_sqlite(source, destination)
    except BackupError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    counts = sorted(made.models_by_status.items())
    models = ", ".join(f"{count} {status}" for status, count in counts)
    print(
        f"backed up {sum(made.models_by_status.values())} model(s) ({models or 'none'}), "
        f"{made.size_bytes / 1e6:.1f} MB, in {made.seconds:.1f} s; integrity check ok",
        file=sys.stderr,
    )
    print(made.path)
    return 0


def backup_sqlite(source: Path, destination: Path) -> Backup:
    """Copy the SQLite database at ``source`` to ``destination`` (see the module's text).

    Raises
    ------
    BackupError
        No database at ``source``, ``destination`` exists already, or the copy failed
        (a full disk, say) or did not pass the integrity check.
    """
    if not source.is_file():
        raise BackupError(f"no database at {source} (SHAPESEARCH_DATA_DIR)")
    if destination.is_dir():
        stamp = datetime.now(UTC).strftime("%Y%m%dT%H%M%SZ")
        destination = destination / f"shapesearch-{stamp}.db"
    if destination.exists():
        raise BackupError(f"{destination} exists: choose another name (a backup never "
                          "overwrites one)")
    partial = destination.with_name(f".{destination.name}.partial")
    started = time.perf_counter()
    try:
        _vacuum_into(source, partial)
        models = _checked_contents(partial)
        partial.replace(destination)
    except (OSError, sqlite3.Error) as error:
        raise BackupError(f"the backup to {destination} failed: {error}") from error
    finally:
        partial.unlink(missing_ok=True)
    return Backup(
        path=destination,
        size_bytes=destination.stat().st_size,
        models_by_status=models,
        seconds=time.perf_counter() - started,
    )


def _vacuum_into(source: Path, target: Path) -> None:
    target.unlink(missing_ok=True)  # a partial file of an interrupted run
    reader = sqlite3.connect(f"{source.resolve().as_uri()}?mode=ro", uri=True, timeout=30)
    try:
        reader.execute("VACUUM INTO ?", (str(target),))
    finally:
        reader.close()


def _checked_contents(path: Path) -> dict[str, int]:
    """Models by status in the copy at ``path``, after SQLite's integrity check of it."""
    copy = sqlite3.connect(path)
    try:
        verdict = copy.execute("PRAGMA integrity_check").fetchall()
        if verdict != [("ok",)]:
            raise sqlite3.DatabaseError(f"integrity check: {verdict[:5]}")
        rows = copy.execute("SELECT status, count(*) FROM models GROUP BY status").fetchall()
    finally:
        copy.close()
    return {str(status): int(count) for status, count in rows}
