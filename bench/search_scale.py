"""Benchmark: search at catalogue scale (10^5 models in a database, 10^6 in an index).

Descriptors are real ones and synthetic ones made from them:

* real: a few dozen CAPOD and parts models are described once with a small point budget
  (``--points``, default 3000) and cached in ``bench/out/search_scale/`` (git-ignored);
* synthetic: each is a real descriptor moved a random fraction (uniform in [0, 0.35]) of
  the way towards another real descriptor, plus isotropic Gaussian noise of expected norm
  ``--noise`` (default 0.08), then renormalised to unit length. So the catalogue forms
  clusters around real shapes whose directions are those of real descriptors, and every
  vector stays unit-norm as the service stores it. Vectors are generated in seeded chunks,
  so exact ground truth at 10^6 is computed chunk by chunk without holding 6 GB. With
  ``--noise-support real`` (index phase) the noise, of the same norm, falls only on the
  dimensions where the real descriptors differ: a histogram bin that no real shape reaches
  stays empty, as it does in a real catalogue (the codes then leave such dimensions out).

Phases (each prints its figures):

``index``  an in-process ``ShapeIndex`` partition with ``--descriptors`` vectors: build
           seconds, RSS growth, search p50/p99 at k=10, recall@10 against exact search,
           batched removal of 1,000 ids.
``db``     for each of ``--backends``: a fresh database (SQLite file, or a PostgreSQL
           schema dropped at the end) filled with ``--models`` ready models, one metadata
           value ``family`` shared by 0.1% of them; then an API process (``shapesearch
           serve --no-worker``): start-up seconds and peak RSS; in-process similar p50/p99
           (with the hub discount, ``--hub-neighbours``, re-ranked k-reciprocally,
           ``--reciprocal``; in plain order and with the discount alone: their cost);
           HTTP ``similar`` p50/p99 and requests/s at each ``--concurrency`` (the API runs
           ``--api-processes`` processes of ``--query-threads`` query threads, by default
           2 of 1, the deployment the README gives for a 2-core host; the load
           generator is a second process on 127.0.0.1, bounded by ``--requests`` and
           ``--seconds`` per level); filtered similar (0.1%-selective metadata, metadata
           that three models in four carry, ``stock``: more than SQL hands the index as
           ids, and a 1%-selective size range); 1,000 deletes.
``duplicates``  for each of ``--backends``: a fresh database of ``--models`` ready models of
           which every 50th is a near copy of the one before (every 200th a second copy:
           triples), so that at ``--duplicates-min-score`` (default 0.999: the synthetic
           catalogue's unrelated nearest neighbours score up to ~0.997, the copies 0.9999+)
           the report holds realistic small groups. The duplicates job as a worker runs it
           (``compute_report`` + ``store_report``, one BLAS thread): seconds per step;
           against, in the same run, the direct all-pairs computation the API ran on every
           page request before (up to ``--duplicates-baseline-max`` models; the groups are
           compared) and n single index searches (timed on a sample, scaled to n); then
           ``GET /v1/duplicates`` p50/p99 over HTTP (c=1, pages anywhere in the report).

Usage (run quietly for figures; the machine's load average is printed with them)::

    nice -n 10 .venv/bin/python -m bench.search_scale                       # everything
    nice -n 10 .venv/bin/python -m bench.search_scale --quick               # 10^4 / 10^5
    .venv/bin/python -m bench.search_scale --phases db --backends sqlite --models 20000
    .venv/bin/python -m bench.search_scale --phases duplicates --backends sqlite --models 100000
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import secrets
import socket
import statistics
import subprocess
import sys
import time
import uuid
from collections.abc import Iterator
from pathlib import Path
from typing import Any

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import numpy as np  # noqa: E402

REPO = Path(__file__).resolve().parent.parent

OUT = REPO / "bench" / "out" / "search_scale"
DATASETS = Path("/work/shared/datasets")
POSTGRES_URL = "postgresql+psycopg://postgres@127.0.0.1:5432/test"
CHUNK = 20_000
FAMILIES = 1000  # metadata "family" takes 1000 values: each one is 0.1% selective
K = 10


# --- descriptors ---------------------------------------------------------------------------


def real_descriptors(count: int, points: int, variant: str | None = None) -> np.ndarray:
    """``(count, d) float32`` unit descriptors of real models, described once and cached
    (per descriptor version: a new default layout is described afresh). ``variant``: an
    evaluation variant's descriptor (``core.evaluation.variants``, e.g. ``ss11``, the
    previous default's width, as a baseline in the same run) instead of the default."""
    from dataclasses import replace

    from app.ingest.describing import pin_blas_threads
    from core.descriptor import DescriptorSpec
    from core.evaluation.variants import VARIANTS
    from core.pipeline import describe
    from core.settings import EngineSettings

    settings = EngineSettings(max_points=points)
    if variant is not None:
        settings = replace(settings, descriptor=VARIANTS[variant].descriptor)
    version = DescriptorSpec.from_settings(settings.descriptor).version(settings)
    cache = OUT / f"real_{count}_{points}_{version.rsplit(';', 1)[-1]}.npy"
    if cache.exists():
        return np.load(cache)
    pin_blas_threads()
    files = sorted(p for p in (DATASETS / "capod").glob("*/*") if p.suffix in {".obj", ".off"})
    parts = sorted(
        p for p in (DATASETS / "parts").iterdir() if p.suffix.lower() in {".stl", ".ply", ".obj"}
    )
    rng = np.random.default_rng(0)
    chosen = list(rng.choice(files, size=min(count - len(parts) // 2, len(files)), replace=False))
    chosen += parts[: count - len(chosen)]
    vectors = []
    for path in chosen:
        start = time.perf_counter()
        try:
            vectors.append(describe(path, settings).descriptor.astype(np.float32))
        except Exception as error:  # an edge case the engine refuses: skip it
            print(f"  skipped {path.name}: {error}", flush=True)
            continue
        print(f"  described {path.name} in {time.perf_counter() - start:.1f}s", flush=True)
    real = np.stack(vectors)
    OUT.mkdir(parents=True, exist_ok=True)
    np.save(cache, real)
    return real


def synthetic_chunk(real: np.ndarray, start: int, size: int, noise: float, *,
                    support: str = "all") -> np.ndarray:
    """Synthetic descriptors ``start .. start + size`` (deterministic per chunk); the noise
    on every dimension (``support`` "all") or only on those where the real descriptors
    differ ("real": a histogram bin that no real shape reaches stays empty)."""
    rng = np.random.default_rng([7, start])
    a = real[rng.integers(len(real), size=size)]
    b = real[rng.integers(len(real), size=size)]
    mix = rng.uniform(0.0, 0.35, size=(size, 1)).astype(np.float32)
    d = real.shape[1]
    noisy = np.ones(d, dtype=bool) if support == "all" else real.max(axis=0) > real.min(axis=0)
    vectors = a + mix * (b - a)
    vectors[:, noisy] += rng.normal(0, noise / np.sqrt(noisy.sum()), size=(size, noisy.sum()))
    vectors = vectors.astype(np.float32)
    vectors /= np.linalg.norm(vectors, axis=1, keepdims=True)
    return vectors


def chunks(real: np.ndarray, total: int, noise: float, *,
           support: str = "all") -> Iterator[tuple[int, np.ndarray]]:
    for start in range(0, total, CHUNK):
        yield start, synthetic_chunk(real, start, min(CHUNK, total - start), noise,
                                     support=support)


def queries(real: np.ndarray, count: int, noise: float, batch: int = 0, *,
            support: str = "all") -> np.ndarray:
    """Fresh descriptors from the same distribution, not in the catalogue (another
    ``batch``, other ones)."""
    return synthetic_chunk(real, 10**9 + batch * 10**6, count, noise, support=support)


def exact_top_k(
    real: np.ndarray, total: int, noise: float, q: np.ndarray, keep: set[int], *,
    support: str = "all",
) -> tuple[np.ndarray, np.ndarray, dict[int, np.ndarray]]:
    """``(n_queries, K)`` ids of the exact nearest neighbours and their ``(n_queries, K)``
    inner products (unit vectors), streamed chunk by chunk, and the vectors of the ids in
    ``keep``."""
    kept: dict[int, np.ndarray] = {}
    best_score = np.full((len(q), K), -np.inf, dtype=np.float32)
    best_id = np.zeros((len(q), K), dtype=np.int64)
    for start, vectors in chunks(real, total, noise, support=support):
        for i in keep:
            if start <= i < start + len(vectors):
                kept[i] = vectors[i - start].copy()
        scores = q @ vectors.T
        ids = np.broadcast_to(np.arange(start, start + len(vectors)), scores.shape)
        all_scores = np.concatenate([best_score, scores], axis=1)
        all_ids = np.concatenate([best_id, ids], axis=1)
        top = np.argsort(-all_scores, axis=1, kind="stable")[:, :K]
        best_score = np.take_along_axis(all_scores, top, axis=1)
        best_id = np.take_along_axis(all_ids, top, axis=1)
    return best_id, best_score, kept


# --- measuring ----------------------------------------------------------------------------


def status_mb(pid: int | str = "self") -> dict[str, float]:
    """The memory lines of ``/proc/PID/status`` in MB: ``VmHWM`` (peak RSS), ``RssAnon``
    (the process's own memory), ``RssFile`` (mapped file pages: for the index, its
    full-vector files in the page cache, which the kernel can always reclaim)."""
    with open(f"/proc/{pid}/status") as status:
        return {
            name: int(value.split()[0]) / 1024
            for name, _, value in (line.partition(":") for line in status)
            if name in ("VmHWM", "VmRSS", "RssAnon", "RssFile")
        }


def api_memory(pid: int) -> str:
    """Memory of the largest API process under ``serve`` process ``pid`` (each API process
    holds its own index): peak RSS, and what it holds now, its own and file-backed."""
    children = Path(f"/proc/{pid}/task/{pid}/children").read_text().split()
    sizes = [status_mb(process) for process in [pid, *map(int, children)]]
    largest = max(sizes, key=lambda size: size["VmHWM"])
    return (
        f"peak RSS {largest['VmHWM']:.0f} MB; now RSS {largest['VmRSS']:.0f} MB = "
        f"anonymous {largest['RssAnon']:.0f} + file-backed {largest['RssFile']:.0f}"
    )


def percentiles(seconds: list[float]) -> str:
    ms = np.asarray(seconds) * 1000
    return f"p50 {np.percentile(ms, 50):.2f} ms  p99 {np.percentile(ms, 99):.2f} ms"


def load_average() -> str:
    return " ".join(f"{v:.2f}" for v in os.getloadavg())


# --- phase: the in-process index ------------------------------------------------------------


def phase_index(args: argparse.Namespace, real: np.ndarray) -> None:
    total = args.descriptors
    print(f"\n== index: {total} descriptors of {real.shape[1]} dims (load {load_average()})")
    import faiss

    faiss.omp_set_num_threads(1)  # as in the API process (pin_blas_threads)
    fresh_milvus(args)
    index = ShapeIndexFromArgs(None, args)
    key = ("bench", "v")
    before = status_mb()
    start = time.perf_counter()
    support = args.noise_support
    index.build_partition(key, chunks(real, total, args.noise, support=support),
                          expected=total)
    build = time.perf_counter() - start
    grown = {name: mb - before[name] for name, mb in status_mb().items()}
    print(
        f"build {build:.1f} s; kind {index.describe(key)}; RSS +{grown['VmRSS']:.0f} MB = "
        f"anonymous +{grown['RssAnon']:.0f} + file-backed +{grown['RssFile']:.0f}"
    )
    print(
        f"index payload (codes, ids, centroids) {index.nbytes() / 1e6:.0f} MB; "
        f"full-vector file {index.file_bytes() / 1e6:.0f} MB"
    )

    rerank = index.rerank_candidates(key, K)
    found, reranked = [], []
    # Three passes of different queries: the first ones after the build (the kernel may
    # still be writing the full-vector file out, and every page is mapped afresh), then
    # the measured ones (warm), then after the page cache dropped the full vectors (cold:
    # read from disk, as under memory pressure).
    passes = (("first after the build", 5 * args.queries, 1), ("warm", args.queries, 0))
    for cache, count, batch in (*passes, ("cold", args.queries, 2)):
        if cache == "cold":
            full = index._partitions[key].full  # noqa: SLF001 (a benchmark's look inside)
            if full is None:
                break
            full.evict()
        q = queries(real, count, args.noise, batch, support=support)
        times, ranking = [], []
        for vector in q:
            # As the service does (app.search.similarity, without the database): candidates from
            # the codes, re-ranked exactly against the index's full vectors.
            t0 = time.perf_counter()
            hits = [i for i, _ in index.search(key, vector, rerank)]
            t1 = time.perf_counter()
            vectors, _ = index.exact_vectors(key, hits)
            order = np.argsort(np.linalg.norm(vectors - vector, axis=1), kind="stable")[:K]
            times.append(time.perf_counter() - t0)
            ranking.append(time.perf_counter() - t1)
            if cache == "warm":
                found.append(hits)
                reranked.append([hits[i] for i in order])
        print(
            f"search k={K} ({rerank} candidates re-ranked exactly), {cache} ({count} queries):"
            f" {percentiles(times)}; of which the re-rank {percentiles(ranking)}"
        )
    q = queries(real, args.queries, args.noise, support=support)
    # Ground truth and the candidates' generated vectors in one streamed pass: the index's
    # full vectors must be those, bit for bit.
    exact, products, rows = exact_top_k(real, total, args.noise, q,
                                        {i for f in found for i in f}, support=support)
    for hits in found:
        held, _ = index.exact_vectors(key, hits)
        assert np.array_equal(held, np.stack([rows[i] for i in hits])), "full vectors differ"
    recall = np.mean([len(set(f) & set(e)) / K for f, e in zip(reranked, exact, strict=True)])
    # How far off a miss is: the 10th answer's distance over the true 10th's (unit vectors:
    # squared distance 2 - 2 x inner product); 1.0 when the answers are the exact ones.
    tenth = [np.linalg.norm(rows[r[K - 1]] - query) for r, query in zip(reranked, q, strict=True)]
    ratio = np.asarray(tenth) / np.sqrt(np.maximum(2 - 2 * products[:, K - 1], 1e-12))
    print(f"recall@{K} vs exact, after exact re-ranking: {recall:.4f}; {K}th distance found / "
          f"exact: mean {ratio.mean():.4f}, max {ratio.max():.4f}")

    if index.hub_neighbours:
        hub_discount_at_scale(index, key, real, args, total)

    doomed = np.random.default_rng(3).choice(total, size=1000, replace=False)
    t0 = time.perf_counter()
    index.remove_many(doomed.tolist())
    print(f"remove 1000 ids (one batch): {(time.perf_counter() - t0) * 1000:.0f} ms")
    now = status_mb()
    print(
        f"peak RSS of this process {now['VmHWM']:.0f} MB; now anonymous "
        f"{now['RssAnon']:.0f} MB + file-backed {now['RssFile']:.0f} MB"
    )
    index.close()


def hub_discount_at_scale(
    index: Any, key: tuple[str, str], real: np.ndarray, args: argparse.Namespace, total: int
) -> None:
    """What the hub discount costs at this size (``app.search.index._kept``): a similar
    query's candidates' radii before any neighbourhood is kept and after the background
    pass has kept them all, the pass itself, and a model added alone (a sync of one ready
    event) with and without them kept: it forgets the neighbourhoods it enters."""
    support = args.noise_support
    candidates = 4 * K  # the discount's pool (app.search.similarity)
    probes = queries(real, args.hub_queries, args.noise, 5, support=support)
    pools = [[i for i, _ in index.search(key, vector, candidates)] for vector in probes]
    fresh = queries(real, 2 * args.adds, args.noise, 6, support=support)

    def radii_times() -> list[float]:
        times = []
        for pool in pools:
            t0 = time.perf_counter()
            index.neighbourhood_radii(key, pool)
            times.append(time.perf_counter() - t0)
        return times

    def single_adds(vectors: np.ndarray, first_id: int) -> list[float]:
        times = []
        for offset, vector in enumerate(vectors):
            t0 = time.perf_counter()
            index.add(first_id + offset, key, vector)
            times.append(time.perf_counter() - t0)
        return times

    unkept = radii_times()  # computed, not kept: a query computes only its own pool's
    index._partitions[key].kept.forget()  # noqa: SLF001 (as before any query)
    plain_adds = single_adds(fresh[: args.adds], 10**8)
    before = status_mb()
    t0 = time.perf_counter()
    kept = index.keep_neighbourhoods()
    seconds = time.perf_counter() - t0
    grown = status_mb()["RssAnon"] - before["RssAnon"]
    kept_radii = radii_times()
    kept_adds = single_adds(fresh[args.adds :], 10**8 + args.adds)
    print(f"hub discount (k={index.hub_neighbours}): a query's {candidates} candidates' radii, "
          f"none kept: {percentiles(unkept)}")
    print(f"the background pass kept {kept} neighbourhoods in {seconds:.0f} s, one thread "
          f"(anonymous memory +{grown:.0f} MB); then the radii: {percentiles(kept_radii)} "
          f"({statistics.median(unkept) / statistics.median(kept_radii):.0f}x faster)")
    print(f"a model added alone ({args.adds} each): none kept {percentiles(plain_adds)}; all "
          f"kept (each forgets those it enters) {percentiles(kept_adds)}")


# --- phase: a database and an API process ---------------------------------------------------


def new_database(backend: str) -> tuple[str, object]:
    """A fresh database URL and a token for ``drop_database``."""
    if backend == "sqlite":
        path = OUT / "bench.db"
        for suffix in ("", "-wal", "-shm"):
            Path(f"{path}{suffix}").unlink(missing_ok=True)
        return f"sqlite:///{path}", path
    from sqlalchemy import create_engine, text
    from sqlalchemy.engine import make_url

    schema = f"shapesearch_bench_{secrets.token_hex(4)}"
    admin = create_engine(POSTGRES_URL, isolation_level="AUTOCOMMIT")
    with admin.connect() as connection:
        connection.execute(text(f'CREATE SCHEMA "{schema}"'))
    admin.dispose()
    url = make_url(POSTGRES_URL).update_query_dict({"options": f"-csearch_path={schema}"})
    return url.render_as_string(hide_password=False), schema


def drop_database(backend: str, token: object) -> None:
    if backend == "sqlite":
        for suffix in ("", "-wal", "-shm"):
            Path(f"{token}{suffix}").unlink(missing_ok=True)
        return
    from sqlalchemy import create_engine, text

    admin = create_engine(POSTGRES_URL, isolation_level="AUTOCOMMIT")
    with admin.connect() as connection:
        connection.execute(text(f'DROP SCHEMA IF EXISTS "{token}" CASCADE'))
    admin.dispose()


def planted_copy(i: int) -> bool:
    """Whether model ``i`` of the duplicates phase is a near copy of model ``i - 1``."""
    return i % 50 == 49 or i % 200 == 198


def fill(
    url: str, real: np.ndarray, total: int, noise: float, copies: bool = False
) -> tuple[list[str], str]:
    """``total`` ready models (family f0..f999, each 0.1%; stock yes for three in four);
    with ``copies``, those that ``planted_copy`` names are near copies of the model before.
    Their public ids, an API key."""
    from sqlalchemy import insert

    from app.auth.keys import create_key
    from app.db.migrate import upgrade
    from app.db.models import Model, utcnow
    from app.db.session import make_engine, make_session_factory

    engine = make_engine(url)
    upgrade(engine)
    ids: list[str] = []
    now = utcnow()
    rng = np.random.default_rng(11)
    with engine.begin() as connection:
        for start, vectors in chunks(real, total, noise):
            if copies:
                for offset in range(1, len(vectors)):
                    if planted_copy(start + offset):
                        moved = vectors[offset - 1] + rng.normal(0, 0.01 / np.sqrt(real.shape[1]),
                                                                 real.shape[1])
                        vectors[offset] = moved / np.linalg.norm(moved)
            rows = []
            for offset, vector in enumerate(vectors):
                model_id = uuid.uuid4()
                ids.append(str(model_id))
                rows.append(
                    {
                        "id": model_id,
                        "tenant": "default",
                        "metadata": {"family": f"f{(start + offset) % FAMILIES}",
                                     "stock": "no" if (start + offset) % 4 == 0 else "yes"},
                        # Lengths 10.0 .. 109.9 mm in 0.1 mm steps: a 1 mm range is 1%.
                        "size_length": 10.0 + ((start + offset) * 7919 % FAMILIES) / 10.0,
                        "size_width": 5.0,
                        "size_height": 2.0,
                        "size_area": 100.0,
                        "units": "mm",
                        "status": "ready",
                        "file_name": "part.stl",
                        "file_size": 1,
                        "file_sha256": "0" * 64,
                        "file_format": "stl",
                        "descriptor": vector.tobytes(),
                        "descriptor_version": "bench",
                        "created_at": now,
                        "updated_at": now,
                    }
                )
            connection.execute(insert(Model.__table__), rows)
    if engine.dialect.name == "postgresql":
        with engine.begin() as connection:  # statistics, as autovacuum would gather them
            connection.exec_driver_sql("ANALYZE models")
    # Served with an API key, as in production (the auth cache is then on the path).
    with make_session_factory(engine).begin() as session:
        key = create_key(session, "default")
    engine.dispose()
    return ids, key


def in_process(url: str, args: argparse.Namespace, model_ids: list[str]) -> None:
    from app.db.session import make_engine, make_session_factory, read_only
    from app.search.sizing import SizeQuery

    engine = make_engine(url)
    sessions = make_session_factory(engine)
    index = ShapeIndexFromArgs(sessions, args)
    t0 = time.perf_counter()
    index.rebuild()
    print(
        f"in-process rebuild {time.perf_counter() - t0:.1f} s, kind {index.describe(KEY)}, "
        f"index payload {index.nbytes() / 1e6:.0f} MB"
    )
    reader = read_only(engine)  # as the API process reads
    rng = np.random.default_rng(5)
    size_range = SizeQuery(ranges={"length": (50.0, 50.95)})  # 1% of the models
    hub, reciprocal = index.hub_neighbours, index.reciprocal
    medians = {}
    cold = "similar, neighbourhoods not yet kept (computed per query)"
    plain = "similar, plain order (hub discount off)"
    alone = "similar, hub discount alone (no k-reciprocal re-rank)"
    for label, filters, size, neighbours, again in (
        # The hub discount before the background pass has kept the neighbourhoods: each
        # query computes its candidates' (and keeps them); then that pass, timed.
        (cold, {}, None, hub, reciprocal),
        ("keep", None, None, hub, reciprocal),
        ("similar", {}, None, hub, reciprocal),
        # The baselines of the same run: plain distance order, no radii to look up; the
        # hub discount without the re-rank (no pairwise products among the candidates).
        (plain, {}, None, 0, False),
        (alone, {}, None, hub, False),
        ("similar, family=f7 (0.1%)", {"family": "f7"}, None, hub, reciprocal),
        ("similar, stock=yes (75%)", {"stock": "yes"}, None, hub, reciprocal),
        ("similar, size.length in [50, 50.95] mm (1%)", {}, size_range, hub, reciprocal),
    ):
        index.hub_neighbours, index.reciprocal = neighbours, again
        if filters is None:
            if hub:
                t0 = time.perf_counter()
                kept = index.keep_neighbourhoods()
                print(f"hub-discount neighbourhoods of {kept} models kept in "
                      f"{time.perf_counter() - t0:.1f} s (an API process: in the background)")
            continue
        times, counts = timed_similar(index, reader, rng.choice(model_ids, size=args.queries),
                                      filters, size)
        print(f"in-process {label} k={K}: {percentiles(times)}; results min {min(counts)}")
        medians[label] = float(np.median(times))
    index.hub_neighbours, index.reciprocal = hub, reciprocal
    import core.rank.reciprocal

    for pool in args.reciprocal_pools:  # the re-rank's cost per pool size
        shipped, core.rank.reciprocal.RECIPROCAL_POOL = core.rank.reciprocal.RECIPROCAL_POOL, pool
        index.reciprocal = True
        times, _ = timed_similar(index, reader, rng.choice(model_ids, size=args.queries))
        core.rank.reciprocal.RECIPROCAL_POOL, index.reciprocal = shipped, reciprocal
        print(f"in-process similar re-ranked among {pool}: {percentiles(times)}; "
              f"{np.median(times) / medians[alone]:.2f}x the discount alone")
    if hub:
        print(f"in-process similar with the hub discount (k {hub}"
              f"{', re-ranked k-reciprocally' if reciprocal else ''}): "
              f"{medians['similar'] / medians[plain]:.2f}x the plain order's median "
              f"({medians[cold] / medians[plain]:.2f}x before the neighbourhoods are kept); "
              f"the discount alone {medians[alone] / medians[plain]:.2f}x")
    with sessions() as session:  # how the database selects a 0.1%-selective filter
        from sqlalchemy import select

        from app.db.models import Model
        from app.search.similarity import sql_filter

        statement = select(Model.index_id).where(
            Model.tenant == "default",
            Model.status == "ready",
            sql_filter(session.connection(), "default", {"family": "f7"}),
        )
        explain = "EXPLAIN QUERY PLAN " if engine.dialect.name == "sqlite" else "EXPLAIN "
        compiled = statement.compile(engine, compile_kwargs={"literal_binds": True})
        from sqlalchemy import text

        plan = session.execute(text(explain + str(compiled))).all()
        print("filter plan: " + " / ".join(str(row[-1]) for row in plan))
    reader.dispose()
    engine.dispose()
    index.close()  # a milvus-lite file: the API process opens it next


KEY = ("default", "bench")


def timed_similar(index: Any, reader: Any, model_ids: np.ndarray,
                  filters: dict[str, str] | None = None, size: Any = None
                  ) -> tuple[list[float], list[int]]:
    """Seconds and result counts of a similar query by each of ``model_ids`` (k ``K``), as
    the route runs it: the query vector from the index, read-only connections."""
    from app.search.similarity import find_similar

    times, counts = [], []
    for model_id in model_ids:
        t0 = time.perf_counter()
        with reader.connect() as connection:
            index_id, key = index.locate("default", uuid.UUID(str(model_id)))
            matches = find_similar(index, connection, key, index.vector(key, index_id), k=K,
                                   filters=filters, exclude=index_id, indexed_query=True,
                                   size=size)
        times.append(time.perf_counter() - t0)
        counts.append(len(matches))
    return times, counts


def ShapeIndexFromArgs(sessions: object, args: argparse.Namespace) -> object:  # noqa: N802
    from app.search.index import ShapeIndex

    return ShapeIndex(
        sessions, exact_max=args.exact_max, compact_min=args.compact_min, nprobe=args.nprobe,
        rerank_factor=args.rerank_factor, projected_dims=args.projected_dims,
        hub_neighbours=args.hub_neighbours, reciprocal=args.reciprocal,
        backend=args.backend, milvus_uri=args.milvus_uri, milvus_index=args.milvus_index,
    )


def fresh_milvus(args: argparse.Namespace) -> None:
    """With ``--backend milvus``: empty collections for the next phase (a milvus-lite file
    of the run's own unless ``--milvus-uri`` names a server)."""
    if args.backend != "milvus":
        return
    if args.milvus_lite:
        OUT.mkdir(parents=True, exist_ok=True)
        args.milvus_uri = str(OUT / f"milvus-{os.getpid()}-{time.monotonic_ns()}.db")
    else:
        from app.search.index._milvus import MilvusStore

        store = MilvusStore(args.milvus_uri)
        store.drop_all()
        store.close()


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def start_api(
    url: str, args: argparse.Namespace
) -> tuple[subprocess.Popen[bytes], str, tuple[float, float]]:
    """The API on a free port, returned once it is ready and (with the hub discount) has
    kept every neighbourhood: the process, its base URL and the seconds to either."""
    import httpx

    port = free_port()
    env = {
        **os.environ,
        "SHAPESEARCH_DATABASE_URL": url,
        "SHAPESEARCH_INDEX_EXACT_MAX": str(args.exact_max),
        "SHAPESEARCH_INDEX_NPROBE": str(args.nprobe),
        "SHAPESEARCH_INDEX_COMPACT_MIN": str(args.compact_min),
        "SHAPESEARCH_INDEX_RERANK_FACTOR": str(args.rerank_factor),
        "SHAPESEARCH_INDEX_PROJECTED_DIMS": str(args.projected_dims),
        "SHAPESEARCH_SEARCH_HUB_NEIGHBOURS": str(args.hub_neighbours),
        "SHAPESEARCH_SEARCH_RECIPROCAL": str(args.reciprocal).lower(),
        "SHAPESEARCH_API_PROCESSES": str(args.api_processes),
        "SHAPESEARCH_QUERY_THREADS": str(args.query_threads),
        "SHAPESEARCH_INDEX_BACKEND": args.backend,
        "SHAPESEARCH_MILVUS_INDEX": args.milvus_index,
    }
    if args.backend == "milvus":
        env["SHAPESEARCH_MILVUS_URI"] = args.milvus_uri
    OUT.mkdir(parents=True, exist_ok=True)
    log = (OUT / "api.log").open("wb")
    t0 = time.perf_counter()
    process = subprocess.Popen(
        [
            str(Path(sys.executable).parent / "shapesearch"),
            "serve",
            "--no-worker",
            "--port",
            str(port),
        ],
        env=env,
        # Its JSON log (one access line per request) goes to a file: a pipe nobody reads
        # fills after ~250 requests and then blocks the server in a logging write.
        stdout=subprocess.DEVNULL,
        stderr=log,
    )
    base = f"http://127.0.0.1:{port}"
    ready_after = None
    while True:
        if process.poll() is not None:
            raise RuntimeError((OUT / "api.log").read_text()[-2000:])
        # Every API process built its index (one "startup complete" line each), and the
        # port answers ready.
        started = (OUT / "api.log").read_text().count("Application startup complete")
        try:
            ready = httpx.get(f"{base}/readyz", timeout=5).status_code == 200
        except httpx.HTTPError:
            ready = False
        if ready and started >= args.api_processes and ready_after is None:
            ready_after = time.perf_counter() - t0
        # With the hub discount, each also keeps every neighbourhood, in the background.
        kept = (OUT / "api.log").read_text().count("hub-discount neighbourhoods of")
        # (Milvus partitions keep no background pass: only what queries compute.)
        if ready_after is not None and (kept >= args.api_processes or not args.hub_neighbours
                                        or args.backend == "milvus"):
            return process, base, (ready_after, time.perf_counter() - t0)
        time.sleep(0.2)


def server_time(offset: int, route: str = "/similar") -> str:
    """p50/p99 of the time the API spent in each request to ``route`` (its access lines'
    ``duration_ms``, from the first ASGI call to the last byte handed to uvicorn) logged after
    byte ``offset`` of the API log: what is left of the client's latency is queueing in the
    kernel and the event loop, and the load generator's own scheduling."""
    with (OUT / "api.log").open("rb") as log:
        log.seek(offset)
        lines = [json.loads(line) for line in log if b'"shapesearch.access"' in line]
    ms = [line["duration_ms"] for line in lines if line.get("route", "").endswith(route)]
    if not ms:
        return "server time: no access lines"
    return f"server time p50 {np.percentile(ms, 50):.1f} ms, p99 {np.percentile(ms, 99):.1f} ms"


def load(
    base: str, args: argparse.Namespace, concurrency: int, paths: list[str], method: str
) -> dict:
    """Run the load generator in a second process; its JSON summary."""
    OUT.mkdir(parents=True, exist_ok=True)
    paths_file = OUT / "paths.json"
    paths_file.write_text(json.dumps(paths))
    command = [
        sys.executable, __file__, "loadgen", base, str(paths_file),
        "--concurrency", str(concurrency), "--requests", str(args.requests),
        "--seconds", str(args.seconds), "--method", method, "--key", args.key,
    ]  # fmt: skip
    return json.loads(subprocess.run(command, check=True, capture_output=True).stdout)


def phase_db(args: argparse.Namespace, real: np.ndarray, backend: str) -> None:
    print(f"\n== {backend}: {args.models} models (load {load_average()})")
    url, token = new_database(backend)
    fresh_milvus(args)
    process = None
    try:
        t0 = time.perf_counter()
        model_ids, key = fill(url, real, args.models, args.noise)
        args.key = key
        print(f"filled in {time.perf_counter() - t0:.0f} s")
        in_process(url, args, model_ids)
        process, base, startup = start_api(url, args)
        print(f"API start-up (to /readyz 200) {startup[0]:.1f} s, hub-discount "
              f"neighbourhoods kept after {startup[1]:.1f} s; {api_memory(process.pid)}")
        rng = np.random.default_rng(9)
        # Distinct query models, each level its own (a model queried twice could find its
        # candidates' order kept, app.search.similarity._orders: each request here is new).
        levels = len(args.concurrency)
        chosen = rng.choice(model_ids, min(len(model_ids), max(5000, args.requests * levels)),
                            replace=False)
        similar = [f"/v1/models/{m}/similar?k={K}" for m in chosen]
        share = len(similar) // levels
        for level, concurrency in enumerate(args.concurrency):
            logged = (OUT / "api.log").stat().st_size
            r = load(base, args, concurrency, similar[level * share : (level + 1) * share],
                     "GET")
            print(
                f"HTTP similar c={concurrency:>2}: {r['rps']:.0f} req/s, p50 {r['p50']:.1f} ms, "
                f"p99 {r['p99']:.1f} ms ({r['count']} requests, errors {r['errors']}; "
                f"load {load_average()}); {server_time(logged)}"
            )
        filtered = [f"{p}&metadata.family=f{i % FAMILIES}" for i, p in enumerate(similar)]
        r = load(base, args, 1, filtered, "GET")
        print(
            f"HTTP similar, 0.1%-selective filter, c=1: p50 {r['p50']:.1f} ms, "
            f"p99 {r['p99']:.1f} ms; "
            f"results min {r['min_results']} (k={K})"
        )
        ranged = [f"{p}&size.length.gte=50&size.length.lte=50.95" for p in similar]
        r = load(base, args, 1, ranged, "GET")
        print(
            f"HTTP similar, 1%-selective size range, c=1: p50 {r['p50']:.1f} ms, "
            f"p99 {r['p99']:.1f} ms; results min {r['min_results']} (k={K})"
        )
        doomed = [f"/v1/models/{m}" for m in rng.choice(model_ids, 1000, replace=False)]
        saved = args.requests
        args.requests = len(doomed)
        r = load(base, args, 16, doomed, "DELETE")
        args.requests = saved
        print(
            f"DELETE 1000 models, c=16: {r['seconds']:.1f} s ({r['rps']:.0f} req/s, "
            f"p50 {r['p50']:.1f} ms), errors {r['errors']}"
        )
        print(f"API memory after the load: {api_memory(process.pid)}")
    finally:
        if process is not None:
            process.terminate()
            process.wait(30)
        drop_database(backend, token)


# --- phase: the duplicates report ------------------------------------------------------------


def direct_groups(sessions: object, min_score: float, k: int = 16) -> set[frozenset[str]]:
    """The previous ``GET /v1/duplicates``, run on every page request: every ready
    descriptor read from the database, an exact all-pairs kNN in one FAISS search, the
    components of the edges at ``min_score``."""
    import faiss
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from sqlalchemy import select

    from app.db.models import Model

    with sessions() as session:  # type: ignore[operator]
        rows = session.execute(
            select(Model.id, Model.descriptor)
            .where(Model.tenant == "default", Model.status == "ready",
                   Model.descriptor_version == "bench")
            .order_by(Model.created_at, Model.id)
        ).all()
    vectors = np.stack([np.frombuffer(row.descriptor, dtype=np.float32) for row in rows])
    index = faiss.IndexFlatIP(vectors.shape[1])
    index.add(vectors)
    cosines, ids = index.search(vectors, k + 1)  # the row itself included
    first = np.repeat(np.arange(len(rows)), ids.shape[1])
    keep = (ids.ravel() >= 0) & (ids.ravel() != first) & ((1 + cosines.ravel()) / 2 >= min_score)
    graph = coo_matrix((np.ones(keep.sum()), (first[keep], ids.ravel()[keep])),
                       shape=(len(rows), len(rows)))
    count, labels = connected_components(graph, directed=False)
    order = np.argsort(labels, kind="stable")
    bounds = np.searchsorted(labels[order], np.arange(count + 1))
    return {
        frozenset(str(rows[i].id) for i in order[bounds[g] : bounds[g + 1]])
        for g in range(count)
        if bounds[g + 1] - bounds[g] >= 2
    }


def planted_groups(model_ids: list[str]) -> set[frozenset[str]]:
    """The groups ``fill(copies=True)`` planted: each model with its near copies."""
    groups: list[list[str]] = []
    for i, model_id in enumerate(model_ids):
        if i > 0 and planted_copy(i):
            groups[-1].append(model_id)
        else:
            groups.append([model_id])
    return {frozenset(group) for group in groups if len(group) >= 2}


def single_searches(real: np.ndarray, args: argparse.Namespace, sample: int = 2000) -> float:
    """Seconds n single index searches (k = 17) would take, one per model, as the graph
    could also be asked for: timed on ``sample`` of them, scaled to n."""
    index = ShapeIndexFromArgs(None, args)
    key = ("default", "bench")
    index.build_partition(key, chunks(real, args.models, args.noise), expected=args.models)
    q = queries(real, min(sample, args.models), args.noise)
    t0 = time.perf_counter()
    for vector in q:
        index.search(key, vector, 17)
    return (time.perf_counter() - t0) * args.models / len(q)


def phase_duplicates(args: argparse.Namespace, real: np.ndarray, backend: str) -> None:
    from app.api.cursors import encode_group
    from app.db.session import make_engine, make_session_factory
    from app.search.duplicate_reports import store_report
    from app.search.duplicates import DuplicatesQuery, compute_report

    print(f"\n== duplicates, {backend}: {args.models} models (load {load_average()})")
    url, token = new_database(backend)
    process = None
    try:
        t0 = time.perf_counter()
        model_ids, key = fill(url, real, args.models, args.noise, copies=True)
        args.key = key
        planted = planted_groups(model_ids)
        print(f"filled in {time.perf_counter() - t0:.0f} s ({len(planted)} planted groups)")
        engine = make_engine(url)
        sessions = make_session_factory(engine)
        query = DuplicatesQuery(descriptor_version="bench", min_score=args.duplicates_min_score)
        t0 = time.perf_counter()  # the job, as a worker runs it
        report = compute_report(
            sessions, "default", query, exact_max=args.exact_max, compact_min=args.compact_min,
            nprobe=args.nprobe, projected_dims=args.projected_dims,
        )
        t1 = time.perf_counter()
        with sessions.begin() as session:
            report_id = store_report(session, "default", report, job_id=None)
        job = time.perf_counter() - t0
        steps = " + ".join(f"{step} {seconds:.1f}" for step, seconds in report.timings.items())
        sizes = [len(group.members) for group in report.groups]
        print(
            f"duplicates job {job:.1f} s = {steps} + store {time.perf_counter() - t1:.1f} s "
            f"(load {load_average()}); min_score {query.min_score}: {len(sizes)} groups "
            f"({sum(sizes)} models, largest {max(sizes, default=0)}), exact {report.exact}"
        )
        found = {frozenset(str(m) for m in group.members) for group in report.groups}
        print(f"planted groups in the report: {len(planted & found)} of {len(planted)}")
        if args.models <= args.duplicates_baseline_max:
            t0 = time.perf_counter()
            direct = direct_groups(sessions, query.min_score)
            seconds = time.perf_counter() - t0
            print(
                f"direct all-pairs (the previous GET, on every page): {seconds:.1f} s, "
                f"{seconds / job:.1f}x the job; groups {len(direct)}, the same in the report "
                f"{len(direct & found)}, only in the report {len(found - direct)}"
            )
        estimate = single_searches(real, args)
        print(f"n single index searches instead of the graph: ~{estimate:.0f} s "
              f"(scaled from 2000), {estimate / report.timings['graph']:.1f}x the graph step")
        engine.dispose()

        process, base, _ = start_api(url, args)
        rng = np.random.default_rng(4)
        first = f"/v1/duplicates?descriptor_version=bench&min_score={query.min_score}"
        pages = [first] + [
            f"/v1/duplicates?cursor={encode_group(report_id, int(n))}"
            for n in rng.integers(0, max(1, len(sizes)), size=999)
        ]
        r = load(base, args, 1, pages, "GET")
        print(
            f"HTTP GET /v1/duplicates (50 groups a page) c=1: p50 {r['p50']:.1f} ms, "
            f"p99 {r['p99']:.1f} ms ({r['count']} requests, errors {r['errors']}); "
            f"{server_time(0, '/duplicates')}"
        )
    finally:
        if process is not None:
            process.terminate()
            process.wait(30)
        drop_database(backend, token)


# --- the load generator (a second process) --------------------------------------------------


async def _generate(base: str, paths: list[str], args: argparse.Namespace) -> dict:
    """``args.concurrency`` keep-alive HTTP/1.1 connections, each sending one request at a
    time; latencies of answered requests. Raw asyncio streams rather than an HTTP client
    library: on 2 cores the generator shares the machine with the server, and a full client
    (httpx) spends more CPU per request than the server does, which would measure the client.
    """
    from urllib.parse import urlsplit

    url = urlsplit(base)
    latencies: list[float] = []
    results: list[int] = []
    errors = 0
    todo = iter(paths[: args.requests] if args.method == "DELETE" else _cycle(paths, args.requests))
    deadline = time.perf_counter() + args.seconds
    head = f"Host: {url.netloc}\r\nAuthorization: Bearer {args.key}\r\n"

    async def user() -> None:
        nonlocal errors
        reader, writer = await asyncio.open_connection(url.hostname, url.port)
        try:
            for path in todo:
                if time.perf_counter() > deadline:
                    return
                t0 = time.perf_counter()
                writer.write(f"{args.method} {path} HTTP/1.1\r\n{head}\r\n".encode())
                try:
                    status, body = await asyncio.wait_for(_response(reader), timeout=30)
                except (TimeoutError, ConnectionError, asyncio.IncompleteReadError):
                    errors += 1  # a timeout under overload counts, and is counted
                    return
                latencies.append(time.perf_counter() - t0)
                if status >= 400:
                    errors += 1
                elif args.method == "GET" and b'"results"' in body:
                    results.append(len(json.loads(body)["results"]))
        finally:
            writer.close()

    start = time.perf_counter()
    await asyncio.gather(*(user() for _ in range(args.concurrency)))
    elapsed = time.perf_counter() - start
    ms = np.asarray(latencies or [float("nan")]) * 1000
    return {
        "count": len(latencies),
        "seconds": elapsed,
        "rps": len(latencies) / elapsed,
        "p50": float(np.percentile(ms, 50)),
        "p99": float(np.percentile(ms, 99)),
        "errors": errors,
        "min_results": min(results) if results else None,
    }


async def _response(reader: asyncio.StreamReader) -> tuple[int, bytes]:
    """One HTTP/1.1 response with a Content-Length body (what uvicorn sends here)."""
    header = await reader.readuntil(b"\r\n\r\n")
    lines = header.decode("latin-1").split("\r\n")
    length = 0
    for line in lines[1:]:
        name, _, value = line.partition(":")
        if name.lower() == "content-length":
            length = int(value)
    return int(lines[0].split()[1]), await reader.readexactly(length)


def _cycle(paths: list[str], count: int) -> Iterator[str]:
    for i in range(count):
        yield paths[i % len(paths)]


def loadgen(argv: list[str]) -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("base")
    parser.add_argument("paths")
    parser.add_argument("--concurrency", type=int, default=1)
    parser.add_argument("--requests", type=int, default=1000)
    parser.add_argument("--seconds", type=float, default=20)
    parser.add_argument("--method", default="GET")
    parser.add_argument("--key", default="")
    args = parser.parse_args(argv)
    paths = json.loads(Path(args.paths).read_text())
    print(json.dumps(asyncio.run(_generate(args.base, paths, args))))


def main() -> None:
    if sys.argv[1:2] == ["loadgen"]:
        loadgen(sys.argv[2:])
        return
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    phases = ["index", "db", "duplicates"]
    parser.add_argument("--phases", nargs="*", default=phases, choices=phases)
    parser.add_argument("--backends", nargs="*", default=["sqlite", "postgresql"])
    parser.add_argument("--models", type=int, default=100_000, help="models in the database")
    parser.add_argument(
        "--descriptors", type=int, default=1_000_000, help="vectors in the index phase"
    )
    from app.settings import Settings

    for setting in ("index_exact_max", "index_compact_min", "index_nprobe",
                    "index_rerank_factor", "index_projected_dims",
                    "search_hub_neighbours"):  # the service's
        parser.add_argument(
            "--" + setting.removeprefix("index_").removeprefix("search_").replace("_", "-"),
            type=int,
            default=Settings.model_fields[setting].default,
            help=f"SHAPESEARCH_{setting.upper()}",
        )
    parser.add_argument(
        "--reciprocal", action=argparse.BooleanOptionalAction,
        default=Settings.model_fields["search_reciprocal"].default,
        help="SHAPESEARCH_SEARCH_RECIPROCAL",
    )
    parser.add_argument(
        "--reciprocal-pools", type=int, nargs="*", default=[], metavar="N",
        help="also time the k-reciprocal re-rank among N candidates (db phase, in-process)",
    )
    parser.add_argument(
        "--api-processes", type=int, default=2, help="SHAPESEARCH_API_PROCESSES (db phase)"
    )
    parser.add_argument(
        "--query-threads", type=int, default=1, help="SHAPESEARCH_QUERY_THREADS (db phase)"
    )
    parser.add_argument("--real", type=int, default=40, help="real models to describe")
    parser.add_argument("--points", type=int, default=3000, help="points per real model")
    parser.add_argument("--variant", help="real descriptors of this evaluation variant "
                        "(e.g. ss11, the previous default) instead of the default")
    parser.add_argument("--noise", type=float, default=0.08, help="norm of the synthetic noise")
    parser.add_argument(
        "--noise-support", choices=("all", "real"), default="all",
        help="index phase: noise on every dimension, or only where the real descriptors differ",
    )
    parser.add_argument("--queries", type=int, default=200, help="queries per in-process figure")
    parser.add_argument("--hub-queries", type=int, default=50,
                        help="index phase: queries whose candidates' radii are timed")
    parser.add_argument("--adds", type=int, default=200,
                        help="index phase: models added one at a time, each way")
    parser.add_argument("--concurrency", type=int, nargs="*", default=[1, 16, 64])
    parser.add_argument("--requests", type=int, default=3000, help="HTTP requests per level")
    parser.add_argument("--seconds", type=float, default=20, help="time bound per level")
    parser.add_argument("--duplicates-min-score", type=float, default=0.999)
    parser.add_argument("--duplicates-baseline-max", type=int, default=20_000,
                        help="largest catalogue the direct all-pairs baseline runs on")
    parser.add_argument("--quick", action="store_true", help="10^4 models, 10^5 descriptors")
    parser.add_argument("--backend", choices=("faiss", "milvus"),
                        default=Settings.model_fields["index_backend"].default,
                        help="SHAPESEARCH_INDEX_BACKEND (index and db phases)")
    parser.add_argument("--milvus-uri", help="SHAPESEARCH_MILVUS_URI: a Milvus server, emptied "
                        "before each phase (default: a fresh milvus-lite file per phase)")
    parser.add_argument("--milvus-index", default=Settings.model_fields["milvus_index"].default,
                        choices=("FLAT", "HNSW", "IVF_FLAT"), help="SHAPESEARCH_MILVUS_INDEX")
    args = parser.parse_args()
    args.milvus_lite = args.backend == "milvus" and not args.milvus_uri
    if args.milvus_lite and args.api_processes > 1:
        print("milvus-lite opens its file in one process: the API runs 1 process")
        args.api_processes = 1
    if args.quick:
        args.models, args.descriptors, args.requests = 10_000, 100_000, 1000
    print(f"search_scale: {vars(args)}; cores {os.cpu_count()}; load {load_average()}")
    real = real_descriptors(args.real, args.points, args.variant)
    print(f"real descriptors {real.shape}")
    if "index" in args.phases:
        phase_index(args, real)
    if "db" in args.phases:
        for backend in args.backends:
            phase_db(args, real, backend)
    if "duplicates" in args.phases:
        for backend in args.backends:
            phase_duplicates(args, real, backend)


if __name__ == "__main__":
    main()
