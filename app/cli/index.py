"""``shapesearch index rebuild|sync|status``: the search index's Milvus collections, from the
database (``SHAPESEARCH_INDEX_BACKEND=milvus``).

``rebuild`` uploads every ready descriptor to Milvus and deletes what Milvus holds of any
other model; ``sync`` writes the change-feed events Milvus lacks (what a running API process
does every second, for a deployment whose API is down); ``status`` tells the revision Milvus
is in step with and the database's. With the FAISS backend each API process builds its own
index at start-up, and these say so and exit 2.
"""

from __future__ import annotations

import sys

from sqlalchemy import select

from app.db.models import FeedState
from app.db.session import open_sessions
from app.search.index import MilvusUnavailable, ShapeIndex
from app.settings import Settings

__all__ = ["run"]


def run(action: str) -> int:
    """Carry out ``action`` (rebuild, sync or status); the exit status."""
    settings = Settings()
    if settings.index_backend != "milvus":
        print("SHAPESEARCH_INDEX_BACKEND is faiss: each API process builds its own index "
              "from the database at start-up; nothing to do", file=sys.stderr)
        return 2
    sessions = open_sessions(settings.resolved_database_url)
    index = ShapeIndex(sessions, **settings.index_options)
    try:
        store = index.milvus
        assert store is not None
        if action == "rebuild":
            index.rebuild(upload=True)
            print(f"Milvus at {store.uri} rebuilt: {len(index)} models, in step with "
                  f"revision {index.revision}", file=sys.stderr)
        elif action == "sync":
            index.rebuild()
            print(f"Milvus at {store.uri} in step with revision {index.revision}",
                  file=sys.stderr)
        else:
            with sessions() as session:
                head = session.execute(
                    select(FeedState.revision).where(FeedState.id == 1)).scalar_one()
            print(f"Milvus at {store.uri}: revision {store.revision()}, the database's "
                  f"{head}; collections {', '.join(store.collections()) or 'none'}")
    except MilvusUnavailable as error:
        print(error, file=sys.stderr)
        return 1
    finally:
        index.close()
    return 0
