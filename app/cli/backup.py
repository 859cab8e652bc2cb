"""``shapesearch backup DEST``: a consistent copy of the service database, taken while the
service runs.

Everything the service keeps (models, their stored files and revisions, descriptors, jobs,
API keys, webhooks, duplicates reports) lives in that one database, and the search index is
rebuilt from it at start-up, so the copy is the whole backup. It is written next to DEST
under a hidden name, checked, and renamed into place only then, so DEST is never a
half-written file; an existing DEST is never overwritten.

* SQLite (the embedded default): ``VACUUM INTO`` writes the copy from one read transaction
  on a read-only connection: the service's writers go on (WAL), the copy holds what was
  committed when it began, compacted, with no ``-wal`` file beside it. Checked with
  ``PRAGMA integrity_check``.
* PostgreSQL: ``pg_dump --format=custom`` (the server's own tool: PostgreSQL's client
  programs must be installed) from a snapshot exported by a repeatable-read transaction, in
  which the models are counted too, so the count is the dump's. Only the service's schema
  when the URL sets a ``search_path``; the password goes to pg_dump in its environment,
  never on its command line. Checked by reading the whole archive back (``pg_restore``
  to nowhere); restore with ``pg_restore --clean --if-exists --no-owner --dbname ...``.
"""
from __future__ import annotations

import os
import re
import shutil
import sqlite3
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path

from sqlalchemy import Connection, create_engine, text
from sqlalchemy.engine import URL, make_url
from sqlalchemy.exc import SQLAlchemyError
from sqlalchemy.pool import NullPool

from app.settings import Settings

__all__ = ["BackupError", "Backup", "backup_postgres", "backup_sqlite", "run"]


class BackupError(Exception):
    """The backup could not be made; the message says why (nothing was left at DEST)."""


@dataclass(frozen=True)
class Backup:
    """A finished backup: where, how large, and what it holds."""

    path: Path
    size_bytes: int
    models_by_status: dict[str, int]
    seconds: float
    check: str  # how the copy was checked


def run(destination: Path) -> int:
    """Back up the configured database to ``destination`` (a file, or a directory for a
    time-stamped file in it); exit code 2 if it could not be made."""
    url = make_url(Settings().resolved_database_url)
    try:
        if url.get_backend_name() == "sqlite":
            made = backup_sqlite(Path(url.database or ""), destination)
        else:
            made = backup_postgres(url, destination)
    except BackupError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    counts = sorted(made.models_by_status.items())
    models = ", ".join(f"{count} {status}" for status, count in counts)
    print(
        f"backed up {sum(made.models_by_status.values())} model(s) ({models or 'none'}), "
        f"{made.size_bytes / 1e6:.1f} MB, in {made.seconds:.1f} s; {made.check} ok",
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

    def copy(partial: Path) -> dict[str, int]:
        _vacuum_into(source, partial)
        return _checked_contents(partial)

    return _written(destination, ".db", copy, check="integrity check")


def backup_postgres(url: URL, destination: Path) -> Backup:
    """Dump the PostgreSQL database at ``url`` to ``destination`` (see the module's text).

    Raises
    ------
    BackupError
        pg_dump is not installed, ``destination`` exists already, the database cannot be
        reached, or the dump failed or could not be read back.
    """
    tools = {name: shutil.which(name) for name in ("pg_dump", "pg_restore")}
    missing = [name for name, path in tools.items() if path is None]
    if missing:
        raise BackupError(f"{' and '.join(missing)} not found: install PostgreSQL's client "
                          "programs (Debian: apt-get install postgresql-client), of the "
                          "server's major version or newer")

    def dump(partial: Path) -> dict[str, int]:
        engine = create_engine(url, poolclass=NullPool)
        try:
            with engine.connect() as connection:
                connection.execution_options(isolation_level="REPEATABLE READ")
                with connection.begin():
                    # The dump reads the data as of this snapshot, while this transaction
                    # stays open; the models are counted in it too.
                    snapshot = connection.execute(text("SELECT pg_export_snapshot()"))
                    models = _models_by_status(connection)
                    _run(tools["pg_dump"], "--format=custom",
                         f"--snapshot={snapshot.scalar_one()}", f"--file={partial}",
                         *_schemas(url), f"--dbname={_libpq(url)}",
                         env=_libpq_environment(url))
        finally:
            engine.dispose()
        # Read back: every block of the archive, its data included, written to nowhere.
        _run(tools["pg_restore"], f"--file={os.devnull}", str(partial))
        return models

    return _written(destination, ".dump", dump, check="archive read back")


def _written(
    destination: Path, suffix: str, write: Callable[[Path], dict[str, int]], *, check: str
) -> Backup:
    """The backup that ``write`` makes at a hidden path (returning the models it holds by
    status), renamed to ``destination`` (a time-stamped name in it if it is a directory)
    once ``write`` has checked it; nothing is left behind if it fails."""
    destination, partial = _new_file(destination, suffix)
    started = time.perf_counter()
    try:
        models = write(partial)
        partial.replace(destination)
    except (OSError, sqlite3.Error, SQLAlchemyError) as error:
        raise BackupError(f"the backup to {destination} failed: {error}") from error
    finally:
        partial.unlink(missing_ok=True)
    return Backup(
        path=destination,
        size_bytes=destination.stat().st_size,
        models_by_status=models,
        seconds=time.perf_counter() - started,
        check=check,
    )


def _new_file(destination: Path, suffix: str) -> tuple[Path, Path]:
    """The backup's path (a time-stamped name in ``destination`` if it is a directory) and
    the hidden name it is written under first."""
    if destination.is_dir():
        stamp = datetime.now(UTC).strftime("%Y%m%dT%H%M%SZ")
        destination = destination / f"shapesearch-{stamp}{suffix}"
    if destination.exists():
        raise BackupError(f"{destination} exists: choose another name (a backup never "
                          "overwrites one)")
    return destination, destination.with_name(f".{destination.name}.partial")


def _models_by_status(connection: Connection) -> dict[str, int]:
    rows = connection.execute(text("SELECT status, count(*) FROM models GROUP BY status"))
    return {str(status): int(count) for status, count in rows}


def _schemas(url: URL) -> list[str]:
    """``--schema`` for each schema of a ``search_path`` set in the URL's ``options``."""
    options = url.query.get("options", "")
    text_options = " ".join(options) if isinstance(options, tuple) else options
    found = re.search(r"-c\s*search_path=(\S+)", text_options)
    names = found.group(1).split(",") if found else []
    return [f"--schema={name.strip()}" for name in names if name.strip()]


def _libpq(url: URL) -> str:
    """``url`` as a libpq connection URI without its password."""
    plain = url.set(drivername="postgresql", password=None)
    return plain.render_as_string(hide_password=False)


def _libpq_environment(url: URL) -> dict[str, str]:
    environment = dict(os.environ)
    if url.password is not None:
        environment["PGPASSWORD"] = str(url.password)
    return environment


def _run(*command: str | None, env: dict[str, str] | None = None) -> None:
    """Run a PostgreSQL client program; OSError with its own message if it fails."""
    finished = subprocess.run([str(part) for part in command], env=env, capture_output=True,
                              text=True, check=False)
    if finished.returncode != 0:
        program = Path(str(command[0])).name
        message = finished.stderr.strip().splitlines()[-1:] or [f"exit {finished.returncode}"]
        raise OSError(f"{program}: {message[0]}")


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
