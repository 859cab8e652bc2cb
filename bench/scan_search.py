"""Benchmark: scan-mode search at catalogue scale, plain order against the hub discount.

Scan mode (``find_similar(..., mode="scan")``) compares a scan with every model's whole
descriptor and its virtual views; it re-orders the
``core.rank.scan_order.scan_depth(k)`` nearest models by scan mode's hub discount, whose radii
cost a search of both partitions per entry, taken best bound first until the answer is
certain; the rest of the pool after the first answer follows that
answer's shape-mode order (``core.rank.scan_order``: the hub discount and the k-reciprocal
re-rank, ``app.search.similarity._scan._scan_hub_order``), before it by a blend of key and
nearness to the first answer, whose radii were searched as the first's; since the
thirty-ninth the pool is ordered from the index's own vectors and the database reads the
answers' rows alone (``_scan_hub_answer``), where it read every candidate's descriptors
first. This measures what that costs.

A SQLite database is filled with ``--models`` ready models, each a synthetic descriptor
(``search_scale.synthetic_chunk``: real descriptors mixed and noised, unit length) with
``--views`` views (the model's vector moved half-way towards other synthetic vectors, so a
view is near its model and unlike its siblings, as real views are). One in-process
``ShapeIndex`` serves both orders: each query runs once in plain order
(``hub_neighbours`` 0) and once with the discount and the service's default k-reciprocal
re-rank (the shape-mode neighbourhoods kept by the pass an API process runs after a
rebuild, ``ShapeIndex.keep_neighbourhoods``), interleaved, the query a fresh synthetic
vector (an upload: no model left out), ``k`` 10 (``--k``). The index keeps the entry neighbours
it searched while the catalogue stays as it is (``app/search/index/_entry_neighbours.py``),
so later queries search only for entries no earlier query met; ``--cold`` forgets them
before every query (a catalogue that changes between any two queries). Printed: build
seconds, median and p90 seconds per order and the ratio of medians, with the machine's load.

    nice -n 10 .venv/bin/python -m bench.scan_search [--models 20000] [--queries 100] [--cold]
        [--scan-pools 40 160] [--anchor-neighbours 0 120]

``--scan-pools`` times scan mode's order at each pool size (``core.rank.scan_order.SCAN_POOL``),
and ``--anchor-neighbours`` with each number of the first answer's nearest models joined to
the pool (``core.rank.scan_order.ANCHOR_NEIGHBOURS``; 0: none, the order before the forty-first
session), each query in every combination, interleaved; the filters' rows take the first
of each. ``--answers FILE`` writes every order's answers (ids,
distances, views) as JSON, so two versions of the code can be compared on one catalogue (the
catalogue and queries are seeded; run the older one with ``PYTHONPATH`` set to a worktree).
``--url`` fills an empty database of one's own (PostgreSQL) in place of a temporary SQLite
file. ``--filters`` also times scan mode's order under two metadata filters, each query in
each: every model carries ``family`` (one of ten values) and ``stock`` (``yes`` for three
models in four); ``family=f3`` is selective (SQL hands the index the matching ids,
``app.search.similarity.matching_ids``), ``stock=yes`` is not (more than ``PUSHDOWN_MAX``
match: the general search asks the index for more and filters the rows).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import tempfile
import time
import uuid
from pathlib import Path

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import numpy as np  # noqa: E402

from bench.search_scale import (  # noqa: E402
    CHUNK,
    load_average,
    queries,
    real_descriptors,
    synthetic_chunk,
)

KEY = ("default", "bench")


# The metadata filters ``--filters`` times: a selective one and a common one.
FILTERS = {"family filter": {"family": "f3"}, "stock filter": {"stock": "yes"}}


def metadata_of(number: int) -> dict[str, str]:
    """Model ``number``'s metadata: ``FILTERS``' selective and common keys."""
    return {"family": f"f{number % 10}", "stock": "no" if number % 4 == 0 else "yes"}


def fill(url: str, real: np.ndarray, models: int, views: int) -> None:
    """``models`` ready models with ``views`` view descriptors each."""
    from sqlalchemy import insert

    from app.db.migrate import upgrade
    from app.db.models import Model, utcnow
    from app.db.session import make_engine

    engine = make_engine(url)
    upgrade(engine)
    now = utcnow()
    with engine.begin() as connection:
        for start in range(0, models, CHUNK):
            size = min(CHUNK, models - start)
            vectors = synthetic_chunk(real, start, size, 0.08)
            others = [synthetic_chunk(real, 10**8 * (1 + v) + start, size, 0.08)
                      for v in range(views)]
            rows = []
            for offset, vector in enumerate(vectors):
                entries = np.stack([vector + other[offset] for other in others])
                entries /= np.linalg.norm(entries, axis=1, keepdims=True)
                rows.append({
                    "id": uuid.uuid4(), "tenant": KEY[0], "status": "ready",
                    "metadata": metadata_of(start + offset),
                    "file_name": "part.stl", "file_size": 1, "file_sha256": "0" * 64,
                    "file_format": "stl", "descriptor": vector.tobytes(),
                    "view_descriptors": entries.astype(np.float32).tobytes(),
                    "descriptor_version": KEY[1], "created_at": now, "updated_at": now,
                })
            connection.execute(insert(Model.__table__), rows)
    if engine.dialect.name == "postgresql":
        with engine.begin() as connection:  # statistics, as autovacuum would gather them
            connection.exec_driver_sql("ANALYZE models")
    engine.dispose()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", type=int, default=20_000)
    parser.add_argument("--views", type=int, default=3)
    parser.add_argument("--queries", type=int, default=100)
    parser.add_argument("--real", type=int, default=40, help="real models to describe")
    parser.add_argument("--cold", action="store_true",
                        help="forget the kept entry neighbours before every query")
    parser.add_argument("--scan-pools", type=int, nargs="+",
                        help="scan mode's pool sizes (core.rank.scan_order.SCAN_POOL) to time, "
                        "each query in every one (default: the shipped one)")
    parser.add_argument("--anchor-neighbours", type=int, nargs="+",
                        help="numbers of the first answer's nearest joined to scan mode's "
                        "pool (core.rank.scan_order.ANCHOR_NEIGHBOURS) to time (default: the "
                        "shipped one)")
    parser.add_argument("--answers", type=Path, help="write every order's answers as JSON")
    parser.add_argument("--k", type=int, default=10, help="results per query")
    parser.add_argument("--url", help="an empty database to fill (e.g. PostgreSQL) in place "
                        "of a temporary SQLite file")
    parser.add_argument("--filters", action="store_true",
                        help="time scan mode's order under a selective and a common filter")
    args = parser.parse_args()

    import core.rank.scan_order
    from app.db.session import make_engine, make_session_factory
    from app.search.index import ShapeIndex, views_key
    from app.search.index._entry_neighbours import KeptEntryNeighbours
    from app.search.similarity import find_similar
    from core.rank.hubness import HUB_NEIGHBOURS

    real = real_descriptors(args.real, 3000)
    with tempfile.TemporaryDirectory() as folder:
        url = args.url or f"sqlite:///{folder}/bench.db"
        started = time.perf_counter()
        fill(url, real, args.models, args.views)
        print(f"filled {args.models} models x {args.views} views, d {real.shape[1]}: "
              f"{time.perf_counter() - started:.0f} s")
        engine = make_engine(url)
        index = ShapeIndex(make_session_factory(engine), reciprocal=True)
        started = time.perf_counter()
        index.rebuild()
        print(f"index built in {time.perf_counter() - started:.0f} s: models "
              f"{index.describe(KEY)}, views {index.describe(views_key(KEY))}")
        started = time.perf_counter()
        kept = index.keep_neighbourhoods()
        print(f"{kept} shape-mode neighbourhoods kept in {time.perf_counter() - started:.0f} s")
        pools = args.scan_pools or [core.rank.scan_order.SCAN_POOL]
        joins = args.anchor_neighbours or [core.rank.scan_order.ANCHOR_NEIGHBOURS]
        orders = [("plain", 0, pools[0], joins[0])] + [
            (f"discount, pool {pool}" + (f", joined {join}" if len(joins) > 1 else ""),
             HUB_NEIGHBOURS, pool, join) for pool in pools for join in joins]
        if args.filters:
            orders += [(name, HUB_NEIGHBOURS, pools[0], joins[0]) for name in FILTERS]
        seconds: dict[str, list[float]] = {order: [] for order, *_ in orders}
        same_first = 0
        written: dict[str, list[list[tuple[int, float, int | None]]]] = {
            order: [] for order, *_ in orders}
        for query in queries(real, args.queries, 0.08, batch=3):
            answers = {}
            for order, neighbours, pool, join in orders:
                index.hub_neighbours = neighbours
                core.rank.scan_order.SCAN_POOL = pool
                core.rank.scan_order.ANCHOR_NEIGHBOURS = join
                if args.cold:
                    index._entry_neighbours = KeptEntryNeighbours()
                t0 = time.perf_counter()
                with engine.connect() as connection:
                    answers[order] = find_similar(index, connection, KEY, query, k=args.k,
                                                  mode="scan", filters=FILTERS.get(order))
                seconds[order].append(time.perf_counter() - t0)
                written[order].append([(m.model.index_id, m.distance, m.view)
                                       for m in answers[order]])
            same_first += (answers["plain"][0].model.index_id
                           == answers[orders[1][0]][0].model.index_id)
        medians = {order: statistics.median(times) for order, times in seconds.items()}
        for order, times in seconds.items():
            p90 = float(np.percentile(times, 90))
            ratio = medians[order] / medians["plain"]
            print(f"{order:30s} median {1000 * medians[order]:.1f} ms, p90 {1000 * p90:.1f} "
                  f"ms, {ratio:.2f}x plain")
        print(f"the same first answer (plain, pool {pools[0]}) for {same_first} of "
              f"{args.queries} queries; entries kept {len(index._entry_neighbours)}; load "
              f"{load_average()}")
        if args.answers:
            args.answers.write_text(json.dumps(written))
        engine.dispose()


if __name__ == "__main__":
    main()
