"""Benchmark: restoring the hub discount's saved neighbourhoods against computing them.

An API process that starts used to compute every model's hub-discount neighbourhood by a
whole pass (``app.search.index._neighbours.keep_neighbourhoods``: about 28 s of a core at
10^5 models, 17 minutes at 10^6), with similar queries computing their candidates' own
meanwhile. Now it restores those its predecessor saved (``app.search.index._saved``),
forgetting what the models changed since moved. Here an in-process ``ShapeIndex`` partition
of ``--descriptors`` synthetic descriptors (``bench/search_scale.py``'s, around real ones):

1. the baseline: a whole pass from nothing, timed;
2. its neighbourhoods saved to a file (timed, with the file's size) and loaded (timed);
3. ``--changes`` models changed (half removed, half added, one at a time), as the running
   process meets a steady import (each forgets the neighbourhoods it moves, ``_kept``),
   then everything forgotten and the file restored with those changes, as a restarted
   process meets them: the restore's time, the share of the partition it keeps, and how
   many of the restored and of the running process's neighbourhoods differ from what a
   whole pass over the changed partition keeps (top-k cosine sum, beyond 1e-5; not with
   ``--no-compare``).

Each of ``--changes`` is a run of its own on the partition built afresh.

    nice -n 5 .venv/bin/python -m bench.neighbourhood_restore [--descriptors 100000]
        [--changes 0 100 1000] [--no-compare]
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

import numpy as np

from app.search.index import ShapeIndex
from app.search.index._kept import Neighbourhood
from app.search.index._saved import (
    SavedNeighbourhoods,
    file_for,
    load,
    restore,
    save,
)
from bench.search_scale import chunks, load_average, queries, real_descriptors

KEY = ("bench", "v")


def timed_pass(index: ShapeIndex) -> tuple[float, int]:
    """Seconds (process CPU: one thread) and count of a whole pass from nothing."""
    index._partitions[KEY].kept.forget()  # noqa: SLF001
    started = time.process_time()
    kept = index.keep_neighbourhoods()
    return time.process_time() - started, kept


def built(real: np.ndarray, args: argparse.Namespace) -> ShapeIndex:
    index = ShapeIndex(None)
    index.build_partition(KEY, chunks(real, args.descriptors, args.noise),
                          expected=args.descriptors)
    return index


def differing(index: ShapeIndex, ids: list[int], entries: list[Neighbourhood | None]) -> str:
    """How many of ``entries`` (kept neighbourhoods of ``ids``, None: not kept) differ from
    what the partition keeps now (a whole pass), and by how much of a radius at most."""
    kept = index._partitions[KEY].kept  # noqa: SLF001
    errors = np.array([abs(entry.top - other.top) / kept.k
                       for entry, other in zip(entries, kept.lookup(ids), strict=True)
                       if entry is not None and other is not None])
    wrong = errors > 1e-5 / kept.k
    largest = errors.max() if len(errors) else 0.0
    return f"{int(wrong.sum())} (radius off by {largest:.1e} at most)"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--descriptors", type=int, default=100_000)
    parser.add_argument("--changes", type=int, nargs="+", default=[0, 100, 1000])
    parser.add_argument("--noise", type=float, default=0.08)
    parser.add_argument("--no-compare", action="store_true",
                        help="no whole pass after the restore to compare it with (at 10^6 "
                        "models it takes as long as the baseline)")
    args = parser.parse_args()

    import faiss

    faiss.omp_set_num_threads(1)  # as in the API process
    real = real_descriptors(40, 3000)
    for changes in args.changes:
        index = built(real, args)
        partition = index._partitions[KEY]  # noqa: SLF001
        kept = partition.kept
        seconds, count = timed_pass(index)
        print(f"{args.descriptors} descriptors of {real.shape[1]} dims, "
              f"{index.describe(KEY)}; load average {load_average()}; baseline, a whole "
              f"pass from nothing: {seconds:.1f} CPU s, {count} kept")
        saved = SavedNeighbourhoods.of(partition, KEY, kept.k, 0, "", kept.saved())
        with tempfile.TemporaryDirectory() as directory:
            path = file_for(Path(directory), KEY, kept.k)
            started = time.perf_counter()
            save(path, saved)
            saving = time.perf_counter() - started
            started = time.perf_counter()
            loaded = load(path, KEY, kept.k)
            loading = time.perf_counter() - started
            size = os.path.getsize(path)
        print(f"  saved in {saving:.2f} s ({size / 1e6:.1f} MB, {size / count:.0f} bytes a "
              f"model), loaded in {loading:.2f} s")
        assert loaded is not None
        # The changes, as the running process meets them (each forgets what it moves).
        rng = np.random.default_rng(7)
        gone = rng.choice(partition.ids(), size=changes // 2, replace=False)
        first = 10**8
        added = queries(real, changes - changes // 2, args.noise, batch=1)
        for offset, (removed, vector) in enumerate(zip(gone.tolist(), added, strict=False)):
            index.remove(removed)  # one change per sync, as a steady import's
            index.add(first + offset, KEY, vector)
        touched = np.concatenate([gone, first + np.arange(len(added))]).astype(np.int64)
        ids = partition.ids().tolist()
        live = kept.lookup(ids)
        kept.forget()  # a new process, from the file
        started = time.perf_counter()
        restored = restore(partition, loaded, touched, kept.version)
        restoring = time.perf_counter() - started
        counted = kept.passed
        share = 0.0 if restored is None else restored / len(ids)
        live_kept = sum(entry is not None for entry in live)
        print(f"  {changes} changes since the save: restored in {restoring:.2f} s "
              f"({restoring / seconds:.4f}x the pass), {share:.1%} kept, counts as its "
              f"pass: {counted}; the running process after the same changes: "
              f"{live_kept / len(ids):.1%} kept")
        if not args.no_compare:
            from_file = kept.lookup(ids)
            timed_pass(index)
            print(f"  not what a whole pass over the changed partition keeps: "
                  f"{differing(index, ids, from_file)} restored, {differing(index, ids, live)} "
                  f"kept by the running process")


if __name__ == "__main__":
    main()
