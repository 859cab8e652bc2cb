"""Benchmark: the hub discount's background pass while parts keep arriving.

An API process keeps every model's hub-discount neighbourhood (``app.search.index._kept``)
by a background pass over the neighbour graph, started once its index is quiet; a change
stops the pass, and the next quiet moment starts another. Until a neighbourhood is kept, a
similar query computes its candidates' own, one index search each. Here an in-process
``ShapeIndex`` partition of ``--descriptors`` synthetic descriptors (``bench/search_scale.py``'s,
around real ones) gets one new model every ``--every`` seconds, as a steady import does, while
a keeper loop does what ``app.api.main``'s does (a look every ``--look`` seconds; a pass when
no model arrived since the last look and the index wants its neighbourhoods).

Two runs on the same index, each from nothing kept, for ``--limit`` seconds:

1. baseline: as before the pass went on where a stopped one ended: every pass starts over
   (``KeptNeighbourhoods.holds_all`` answering no), and a pass is wanted while fewer than
   half of the neighbourhoods are kept;
2. the service's pass: blocks whose neighbourhoods are all kept are left out, and a pass
   stopped by a change is wanted again until one reaches its end.

A similar query's index work (its candidates and their radii) runs every ``--query-every``
seconds meanwhile. Prints, for each run, the seconds until the index stopped wanting a pass
(``KeptNeighbourhoods.wanted``; a neighbourhood not kept is computed by the query that needs
it, one index search each, and kept), the passes started, the CPU seconds they used, and the
share kept at the limit, and the queries' latency over the run's second half, against the
same queries with every neighbourhood kept and nothing arriving; and how long adding each
arriving model took (it waits for the partition's write lock).

    nice -n 5 .venv/bin/python -m bench.neighbourhood_pass [--descriptors 100000]
        [--every 10] [--look 1] [--limit 300]
"""

from __future__ import annotations

import argparse
import threading
import time
from typing import Any

import numpy as np

from app.search.index import ShapeIndex
from bench.search_scale import (
    chunks,
    percentiles,
    queries,
    real_descriptors,
)

KEY = ("bench", "v")


def similar_query(index: ShapeIndex, vector: np.ndarray) -> float:
    """Seconds of a similar query's index work: its ``4 k`` candidates and their radii (each
    computed by one index search when its neighbourhood is not kept)."""
    started = time.perf_counter()
    pool = [i for i, _ in index.search(KEY, vector, 40)]
    index.neighbourhood_radii(KEY, pool)
    return time.perf_counter() - started


def keep_while_arriving(
    index: ShapeIndex, fresh: np.ndarray, probes: np.ndarray, first_id: int,
    args: argparse.Namespace,
) -> tuple[float | None, int, float, float, list[float], list[float]]:
    """Run the keeper beside the arrivals and a query every ``--query-every`` seconds, for
    ``--limit`` seconds: when the index stopped wanting a pass (None: never), the passes
    started, their CPU seconds, the share of neighbourhoods kept at the end, the queries'
    seconds and the arrivals' (each model added alone, as a sync applies it)."""
    partition = index._partitions[KEY]  # noqa: SLF001 (a benchmark's look inside)
    kept = partition.kept
    kept.forget()
    stop = threading.Event()
    held = list(range(args.descriptors))
    answered: list[float] = []

    def queries_meanwhile() -> None:
        while not stop.wait(args.query_every):
            answered.append(similar_query(index, probes[len(answered) % len(probes)]))

    adds: list[float] = []

    def arrivals() -> None:
        while not stop.wait(args.every):
            new_id = first_id + len(held)
            started = time.perf_counter()
            index.add(new_id, KEY, fresh[len(held) % len(fresh)])
            adds.append(time.perf_counter() - started)
            held.append(new_id)

    passes, cpu = [0], [0.0]

    def one_pass() -> None:
        started = time.thread_time()
        index.keep_neighbourhoods()
        cpu[0] += time.thread_time() - started

    adder = threading.Thread(target=arrivals, daemon=True)
    adder.start()
    asker = threading.Thread(target=queries_meanwhile, daemon=True)
    asker.start()
    keeper: threading.Thread | None = None
    started = time.monotonic()
    satisfied: float | None = None
    seen = len(held)
    while time.monotonic() - started < args.limit:
        time.sleep(args.look)
        quiet, seen = len(held) == seen, len(held)
        if keeper is not None and keeper.is_alive():
            continue
        wanted = index.wants_neighbourhoods()
        if not wanted and satisfied is None and passes[0]:
            satisfied = time.monotonic() - started
        if quiet and wanted:
            keeper = threading.Thread(target=one_pass, daemon=True)
            keeper.start()
            passes[0] += 1
    share = float(kept.holding(np.asarray(held, dtype=np.int64)).mean())
    stop.set()
    adder.join()
    asker.join()
    if keeper is not None:
        keeper.join()  # uninterrupted now: what it keeps from here on is not counted
    return satisfied, passes[0], cpu[0], share, answered, adds


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--descriptors", type=int, default=100_000)
    parser.add_argument("--every", type=float, default=10.0, help="seconds between arrivals")
    parser.add_argument("--look", type=float, default=1.0,
                        help="seconds between the keeper's looks")
    parser.add_argument("--limit", type=float, default=300.0, help="seconds per run at most")
    parser.add_argument("--query-every", type=float, default=0.1,
                        help="seconds between two similar queries")
    parser.add_argument("--noise", type=float, default=0.08)
    args = parser.parse_args()

    import faiss

    faiss.omp_set_num_threads(1)  # as in the API process
    real = real_descriptors(40, 3000)
    index = ShapeIndex(None)
    index.build_partition(KEY, chunks(real, args.descriptors, args.noise),
                          expected=args.descriptors)
    print(f"{args.descriptors} descriptors of {real.shape[1]} dims, {index.describe(KEY)}; "
          f"a model every {args.every:g} s, a look every {args.look:g} s, limit {args.limit:g} s")
    fresh = queries(real, 1000, args.noise)
    probes = queries(real, 5000, args.noise, batch=1)  # a query is rarely asked twice
    index.keep_neighbourhoods()
    idle = [similar_query(index, vector) for vector in probes]
    print(f"a query's index work, every neighbourhood kept, nothing arriving: "
          f"{percentiles(idle)}")
    kept_class = type(index._partitions[KEY].kept)  # noqa: SLF001
    service = kept_class.holds_all, kept_class.wanted

    def wanted_before(self: Any, k: int, held: int) -> bool:  # a stopped pass not counted
        return (held >= k + 2 and self.pass_version != self.version
                and (self.k != k or len(self) < held / 2))

    for name, first_id in (("baseline: every pass starts over", 10**8),
                           ("the service's pass", 2 * 10**8)):
        if name.startswith("baseline"):
            kept_class.holds_all = lambda self, ids: False  # type: ignore[method-assign]
            kept_class.wanted = wanted_before  # type: ignore[method-assign]
        else:
            kept_class.holds_all, kept_class.wanted = service  # type: ignore[method-assign]
        satisfied, passes, cpu, share, answered, adds = keep_while_arriving(
            index, fresh, probes, first_id, args)
        reached = ("still wanted at the limit" if satisfied is None
                   else f"no longer wanted after {satisfied:.0f} s")
        late = answered[len(answered) // 2:]  # the second half of the run
        print(f"{name}: {reached}; {passes} passes started, {cpu:.0f} CPU s; "
              f"{share:.1%} of the neighbourhoods kept at the limit; a query's index work "
              f"in the run's second half: {percentiles(late)} ({len(late)} queries); a "
              f"model added: {percentiles(adds)}, longest {max(adds) * 1e3:.0f} ms")
    kept_class.holds_all, kept_class.wanted = service  # type: ignore[method-assign]


if __name__ == "__main__":
    main()
