"""The migrations build the schema the models declare: a table, column or index added to
``app/db/models.py`` without its Alembic revision (or the other way round) fails here, on
SQLite and PostgreSQL alike."""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest
from alembic.autogenerate import compare_metadata
from alembic.migration import MigrationContext

from app.db.migrate import is_at_head, upgrade
from app.db.models import Base
from app.db.session import make_engine

# Differences that are meant: metadata filters use a GIN index on PostgreSQL (revision
# 0005) and on SQLite a lookup table kept by triggers (revision 0007), both outside the
# models; SQLite does not enforce a VARCHAR's length, so revision 0008 lengthens
# descriptor_version on PostgreSQL only.
_POSTGRESQL_ONLY = {("remove_index", "ix_models_metadata_gin")}
_SQLITE_ONLY = {
    ("remove_table", "metadata_values"),
    ("remove_index", "ix_metadata_values_lookup"),
    ("remove_index", "ix_metadata_values_model"),
    ("modify_type", "descriptor_version"),
}


def _named(difference: Any) -> tuple[str, str]:
    if isinstance(difference, list):  # column changes come as a list of one
        (change,) = difference
        return change[0], change[3]
    return difference[0], difference[1].name


def test_the_migrated_schema_is_the_models_schema(database_url: str) -> None:
    engine = make_engine(database_url)
    try:
        upgrade(engine)
        with engine.connect() as connection:
            differences = compare_metadata(MigrationContext.configure(connection),
                                           Base.metadata)
    finally:
        engine.dispose()
    found = {_named(difference) for difference in differences}
    expected = _SQLITE_ONLY if engine.dialect.name == "sqlite" else _POSTGRESQL_ONLY
    assert found == expected


# A process that opens the database at a given moment, as `serve` and `shapesearch worker`
# started together do; prints what its start-up migration did.
_START_AT = """
import sys, time
from app.db.migrate import upgrade
from app.db.session import make_engine
engine = make_engine(sys.argv[1])
while time.time() < float(sys.argv[2]):
    time.sleep(0.0005)
upgrade(engine)
print("migrated")
"""


@pytest.mark.slow
@pytest.mark.parametrize("start", ["empty", "0013"])
def test_two_processes_starting_at_once_on_one_sqlite_file_both_migrate_it(
    tmp_path: Path, start: str,
) -> None:
    """Alembic reads the schema before it writes; on SQLite a transaction that read first
    cannot take the write lock once another process committed, so of two processes started
    together after an upgrade one died with "database is locked" (6 of 6 trials). The
    migration now takes the lock at its BEGIN, and the second waits for the first. On a new
    file, turning it to WAL mode failed the same way at connect (2 of 6 trials); it is now
    tried again until the busy timeout."""
    url = f"sqlite:///{tmp_path / 'shapesearch.db'}"
    if start != "empty":
        engine = make_engine(url)
        upgrade(engine, start)
        engine.dispose()
    at = str(time.time() + 3.0)  # both processes have imported the app by then
    root = Path(__file__).parents[2]
    processes = [
        subprocess.Popen([sys.executable, "-c", _START_AT, url, at], cwd=root, text=True,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        for _ in range(2)
    ]
    outputs = [process.communicate(timeout=120) for process in processes]
    assert [process.returncode for process in processes] == [0, 0], outputs
    assert all(out.strip() == "migrated" for out, _ in outputs)
    engine = make_engine(url)
    try:
        assert is_at_head(engine)
    finally:
        engine.dispose()


# The first process of two: it pauses after its first statement (so the second can start)
# and after each commit (so the second could take the lock between two migrations, had the
# first let it go in between).
_FIRST_PAUSES = """
import sys, time
from pathlib import Path
from sqlalchemy import event
from app.db.migrate import upgrade
from app.db.session import make_engine
engine = make_engine(sys.argv[1])

@event.listens_for(engine, "after_cursor_execute")
def _started(*_args):
    marker = Path(sys.argv[2])
    if not marker.exists():
        marker.touch()
        time.sleep(0.5)

commit = engine.dialect.do_commit

def _commit_then_pause(dbapi_connection):
    commit(dbapi_connection)
    time.sleep(1.0)

engine.dialect.do_commit = _commit_then_pause
upgrade(engine)
print("migrated")
"""


# The second process: imported and waiting before the first starts, it migrates as soon as
# the first has run a statement.
_SECOND_WAITS = """
import sys, time
from pathlib import Path
from app.db.migrate import upgrade
from app.db.session import make_engine
engine = make_engine(sys.argv[1])
Path(sys.argv[3]).touch()
while not Path(sys.argv[2]).exists():
    time.sleep(0.005)
upgrade(engine)
print("migrated")
"""


def _wait_for(path: Path, process: subprocess.Popen[str]) -> None:
    deadline = time.monotonic() + 60
    while not path.exists() and process.poll() is None and time.monotonic() < deadline:
        time.sleep(0.01)
    assert path.exists(), process.communicate()


@pytest.mark.slow
def test_a_process_starting_while_another_migrates_waits_for_its_whole_upgrade(
    tmp_path: Path,
) -> None:
    """Alembic commits after each migration on SQLite (it does not count SQLite's DDL as
    transactional), so a second process could take the lock between two of the first's
    migrations, read the revision reached so far and run the next ones itself; the first
    then ran them again ("No such constraint: 'uq_jobs_model_id'", once in CI). The whole
    upgrade is now one transaction: the second process waits for all of it."""
    url = f"sqlite:///{tmp_path / 'shapesearch.db'}"
    started, ready = tmp_path / "first-statement-ran", tmp_path / "second-ready"
    root = Path(__file__).parents[2]
    second = subprocess.Popen(
        [sys.executable, "-c", _SECOND_WAITS, url, str(started), str(ready)],
        cwd=root, text=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    _wait_for(ready, second)
    first = subprocess.Popen([sys.executable, "-c", _FIRST_PAUSES, url, str(started)],
                             cwd=root, text=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    outputs = [process.communicate(timeout=120) for process in (first, second)]
    assert [first.returncode, second.returncode] == [0, 0], outputs
    engine = make_engine(url)
    try:
        assert is_at_head(engine)
    finally:
        engine.dispose()
