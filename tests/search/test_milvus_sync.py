"""The Milvus backend's collections follow the database through kills: a process killed with
SIGKILL between the database and Milvus (vectors written, the revision not; or models
removed, their replacements not written) loses and duplicates nothing once any process
syncs again.

The syncing processes are subprocesses (milvus-lite opens its file in one process at a
time), each killing itself at the chosen point by a patched ``MilvusStore`` method."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
from sqlalchemy import func, select
from sqlalchemy.orm import Session, sessionmaker

from app.db.models import FeedState, Model
from app.search.index import view_id
from tests.search.conftest import milvus_missing
from tests.search.test_index import add_ready, delete_model, unit

REPO = Path(__file__).resolve().parents[2]

# A child: sync the index of database ARGV[1] with Milvus at ARGV[2], dying by SIGKILL in
# ``MilvusStore.<ARGV[3]>`` instead of running it, or, with "report", printing what Milvus
# holds afterwards.
_CHILD = textwrap.dedent("""
    import json, os, signal, sys
    from app.db.session import make_engine, make_session_factory
    from app.search.index import ShapeIndex
    from app.search.index._milvus import MilvusStore

    url, uri, action = sys.argv[1:4]
    die = lambda *a, **k: os.kill(os.getpid(), signal.SIGKILL)
    if action == "set_revision":
        MilvusStore.set_revision = die
    elif action == "upsert":
        MilvusStore.upsert = die
    index = ShapeIndex(make_session_factory(make_engine(url)), backend="milvus",
                       milvus_uri=uri)
    index.rebuild()
    if action == "report":
        store = index.milvus
        held = {}
        for name in store.collections():
            ids = [int(i) for batch in store.ids(name) for i in batch]
            held[name] = {"ids": ids, "count": store.count(name)}
        print(json.dumps({"revision": store.revision(), "held": held,
                          "models": len(index)}))
    index.close()
""")


def _child(url: str, uri: str, action: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-c", _CHILD, url, uri, action], cwd=REPO,
                          capture_output=True, text=True, timeout=120)


def _killed(url: str, uri: str, action: str) -> None:
    done = _child(url, uri, action)
    assert done.returncode == -signal.SIGKILL, done.stderr[-2000:]


@pytest.mark.slow
def test_a_sync_killed_between_the_database_and_milvus_loses_and_duplicates_nothing(
    sessions: sessionmaker[Session], database_url: str, tmp_path: Path,
) -> None:
    if reason := milvus_missing():
        pytest.skip(reason)
    uri = str(tmp_path / "milvus.db")
    views = np.stack([unit(50 + i) for i in range(3)])
    first = [add_ready(sessions, unit(i)) for i in range(4)]
    viewed = add_ready(sessions, unit(9), views=views)
    assert _child(database_url, uri, "sync").returncode == 0  # uploaded, then in step

    added = [add_ready(sessions, unit(10 + i)) for i in range(3)]
    delete_model(sessions, first[0])
    _killed(database_url, uri, "set_revision")  # written to Milvus, revision not recorded

    delete_model(sessions, first[1])
    delete_model(sessions, viewed)  # its views go too
    added.append(add_ready(sessions, unit(20), views=views[:2]))
    _killed(database_url, uri, "upsert")  # removed from Milvus, the additions never written

    done = _child(database_url, uri, "report")
    assert done.returncode == 0, done.stderr[-2000:]
    report = json.loads(done.stdout.strip().splitlines()[-1])
    with sessions() as session:
        ready = set(session.scalars(select(Model.index_id).where(Model.status == "ready")))
        head = session.execute(select(FeedState.revision).where(FeedState.id == 1)).scalar_one()
        assert session.scalar(select(func.count()).select_from(Model)) == len(ready)
    assert ready == {*first[2:], *added}
    held = [i for collection in report["held"].values() for i in collection["ids"]]
    counted = sum(collection["count"] for collection in report["held"].values())
    assert len(held) == len(set(held)) == counted  # nothing duplicated
    assert set(held) == ready | {view_id(added[-1], 0), view_id(added[-1], 1)}  # nothing lost
    assert report["revision"] == head and report["models"] == len(ready)
