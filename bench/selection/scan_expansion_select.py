"""Issue 24, item 5: do a scan's first answers, taken whole, order the rest of its answers better?

Why: single-view scans in scan mode still miss the issue's aim (mAP >= 0.6) on MCAD,
py-gearworks, BOSL2 and our generator, while the first answer is right far more often than
the rest of the kind is found (single views, this session's draw: pymadcad NN 0.917 at mAP
0.676, BOSL2 0.808 at 0.585, bd-vslot 0.854 at 0.715). A partial scan is far from every whole
model; its first answers are whole models, and among whole models the descriptor finds a
kind well (clean queries in scan mode: mAP 0.816, mean of seven). Completing the scan's
geometry about its axis did not help (``scan_revolve_select.py``): it lost the details that
tell kinds apart. Here the scan is completed by retrieval instead: the rest of the answer is
ordered partly by how near each candidate lies to the first answers' whole descriptors
(query expansion for scans). Shape mode's query expansion was declined
(``query_expansion_select.py``, +0.0001): there the query is already whole. Nothing is
fitted.

Candidates, written before any score of them was seen (7):

- ``shipped`` (the reference): scan mode as it ships, a model's key ``s`` the least
  ``|q - e|^2 + 0.5 r(e)`` over its entries (``core.rank.hubness.scan_hub_keys``, k 5);
- ``m<m> w<w>``: among the pool the service re-orders (the ``D`` = 40 models of lowest
  ``s``: ``rerank_depth(10)``), the anchors are the ``m`` of lowest ``s``; each pool model
  ``p`` gets ``c(p)``, the mean over the anchors ``a`` of ``|x_p - x_a|^2`` (``x`` a model's
  whole descriptor), and the key ``(1 - w) s(p) + w c(p)``; the first answer (lowest ``s``)
  stays first, the rest of the pool follows by that key, models outside the pool after it
  in ``s`` order. ``m`` in {1, 3}, ``w`` in {0.25, 0.5, 0.75}.

Leave-one-out as everywhere: a query is a scan of one model, whose entries leave the
catalogue for it, and no radius counts that model.

Data: the fifteenth and sixteenth sessions' ``python -m core.evaluation.scan_retrieval``
outputs per source (``scan_revolve_select.py``'s run serves: its raw kinds are
``scan_hubs_select.py``'s), each model queried as a single-view scan, a merged three-view
scan and a clean copy against its source's catalogue (each model whole and as 3 views).

The rule (``profile_block_select.decide``, as every study since the ring block): single-view
scan mAP of the default descriptor per source, the mean over the seven tuning sources
(madcad, gearworks, vslot, mcad, generated, bendable, capod), ties within 0.002 to
``shipped`` first, then the smaller ``m``, then the smaller ``w``; leave-one-source-out with
a 95 % paired bootstrap over queries against ``shipped``. It ships only if all hold:

1. the rule's test: the leave-one-source-out mean above ``shipped``'s by more than 0.002,
   the interval above zero;
2. the choice over all seven: merged three-view scans' mean mAP over the seven and clean
   queries' (in scan mode) each not below ``shipped``'s by more than 0.002;
3. BOSL2, which chose nothing here (the judge): the choice's single-view mAP not below
   ``shipped``'s by more than 0.002;
4. the ``bendable`` family (the search is one for both families): its single-view mean over
   (bendable, capod-nonrigid) not below ``shipped``'s by more than 0.002.

Cost, stated before the run: the pool's whole descriptors are already read for the answer;
the re-order is ``D x m`` distances per query.

    .venv/bin/python bench/selection/scan_expansion_select.py /work/scanrev \\
        --json /work/scanrev/expansion.json

**Result** (2026-11-27, sixteenth session; docs/results.md, "The first answers, taken whole,
order the rest of a scan's answers"): the rule chose ``m1 w0.75`` on the seven and without
each of them; single-view scans left out +0.0731 (95 % +0.0561 .. +0.0910) against
``shipped`` (mean of seven 0.6106 -> 0.6837, every source up); merged scans 0.6957 ->
0.7338, clean queries 0.8161 -> 0.8190; BOSL2 0.585 -> 0.670; the ``bendable`` family
0.7522 -> 0.7918: all four tests pass, it ships (``core.rank.hubness.scan_ranking``,
``SCAN_EXPANSION_WEIGHT``; the service's scan mode since). Disclosed: the grid's edge (one
anchor, the largest weight). After the run the rule and tests moved into
``scan_hubs_select.rule_and_tests``, shared with the other two scan studies (their choices,
left-out figures and tests unchanged, checked on the JSON).

Replication on another draw (reading written before the run): every model rotated and
scanned again with ``--rotation-seed 2`` (``scan_retrieval``; kinds clean, multi+sor,
single+sor; the same sources), and this script run unchanged on it. The choice replicates
if the rule's choice there passes all four tests and ``m1 w0.75`` is within the tie (0.002)
of it; otherwise the difference is reported and the shipped setting stays until a third
draw decides.

**Round 2, written after round 1's result and before any score of it (disclosed as such;
thirty-eighth session).** Round 1 chose its grid's edge (one anchor, the largest weight),
and it measured the rest of the pool's nearness to the first answer in plain distance,
while a whole query (shape mode) is ordered better by the hub discount (+0.011 left out)
and the k-reciprocal re-rank over it (+0.017): the first answer is a whole model, so its
shape-mode order may be what the rest of a scan's answer should follow. One anchor (the
first answer ``a``) throughout; candidates, in the tie order (7):

- ``shipped`` (the reference): ``m1 w0.75``, plain nearness ``c(p) = |x_p - x_a|^2``;
- ``plain w0.9``, ``plain w1``: the same nearness, more weight (at 1 the scan's own key
  no longer orders the rest of the pool);
- ``hub w0.75``, ``hub w0.9``, ``hub w1``: ``c(p)`` the shape-mode hub key of ``p`` for
  the query ``x_a``, ``|x_p - x_a|^2 + r_10(p)`` (``core.rank.hubness.hub_keys``,
  ``HUB_NEIGHBOURS`` 10, ``HUB_WEIGHT`` 1; ``r_10`` over the source's whole descriptors,
  the scanned model left out, as a shape query leaves itself out);
- ``service w1``: the rest of the pool in the order the service gives the shape query
  ``x_a`` among it (``core.rank.reciprocal.pool_keys``: the k-reciprocal re-rank over the hub
  keys above, ``k1`` 5, ``k2`` 3, blend 0.1). Its keys are Jaccard distances, not in the
  scan key's units, so only weight 1 is asked.

The rule, the four ship tests and the data are round 1's (``scan_hubs_select.rule_and_tests``,
``shipped`` the reference). A fifth test, because round 1's choice needed a second draw to
be trusted: the choice, if it passes the four, must be chosen again (or be within the tie of
the choice) on the second draw (``--rotation-seed 2``) with the four tests passing there;
until that draw is scored it is reported, not shipped. Cost, stated before the run: ``hub``
reads radii the index keeps for shape mode; ``service`` adds one ``pool_keys`` per scan
query (shape mode's re-rank of 40 candidates, measured at 1.4-1.6x the discount's time).
``--round 2`` runs it:

    .venv/bin/python bench/selection/scan_expansion_select.py /work/scanrev --round 2 \\
        --json /work/scanrev/expansion_round2.json

**Round 2 result** (2026-12-05, thirty-eighth session; docs/results.md, "The rest of a
scan's answers in its first answer's own order"): the rule chose ``service w1`` on the seven
and without each of them; single-view scans left out +0.0154 (95 % +0.0104 .. +0.0210)
against ``shipped`` (mean of seven 0.6905 -> 0.7059); merged scans 0.7486 -> 0.7677, clean
queries 0.8421 -> 0.8647; BOSL2 0.696 -> 0.721; the ``bendable`` family 0.8203 -> 0.8332:
the four tests pass. The fifth, on the second draw (``/work/scanrev2``, this script
unchanged): ``service w1`` again, +0.0118 (+0.0068 .. +0.0172), the four tests pass there
(merged 0.7407 -> 0.7563, clean 0.8423 -> 0.8647, BOSL2 0.703 -> 0.720, family 0.8533 ->
0.8774). Ships: ``core.rank.scan_order``. Disclosed: after the first run the scanned model was
left out of a pool larger than its source (capod's non-rigid classes, 30 models), whose
vector had entered ``service w1``'s neighbourhoods; only the family figure moved (0.8315 ->
0.8332).
"""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from profile_block_select import Table  # noqa: E402
from scan_hubs_select import (  # noqa: E402
    Catalogue,
    ranked_scores,
    run_study,
    source_catalogue,
    study_arguments,
    tabulate,
)

from core.rank.hubness import HUB_NEIGHBOURS, hub_keys, neighbourhood_radii, scan_hub_keys  # noqa: E402
from core.rank.reciprocal import pool_keys  # noqa: E402

POOL = 40  # app.search.similarity: rerank_depth(10)
ANCHORS = (1, 3)
WEIGHTS = (0.25, 0.5, 0.75)
SHIPPED = "shipped"
#: Round 2: the nearness to the first answer and the weights asked of it.
NEARNESS = ("plain", "hub", "service")
ROUND_2_WEIGHTS = {"plain": (0.75, 0.9, 1.0), "hub": (0.75, 0.9, 1.0), "service": (1.0,)}
SHIPPED_WEIGHT = 0.75


def candidates() -> dict[str, tuple[int, float]]:
    """Candidate name -> (anchors, weight), in the rule's tie order (``shipped`` first, then
    the smaller ``m``, the smaller ``w``)."""
    grid: dict[str, tuple[int, float]] = {SHIPPED: (0, 0.0)}
    for anchors in ANCHORS:
        for weight in WEIGHTS:
            grid[f"m{anchors} w{weight:g}"] = (anchors, weight)
    return grid


def whole_rows(catalogue: Catalogue) -> np.ndarray:
    """``(models, d)``: each model's whole descriptor."""
    whole = ~catalogue.is_view
    rows = np.empty((len(catalogue.models), catalogue.entries.shape[1]))
    rows[catalogue.owners[whole]] = catalogue.entries[whole]
    return rows


def expanded_order(keys: np.ndarray, whole: np.ndarray, own: int | None, anchors: int,
                   weight: float) -> np.ndarray:
    """Ranking keys ``(models,)`` (lower first) of one query: ``keys`` re-ordered within the
    pool as the candidate says; ``own`` (the query's model, if not already ``inf`` in
    ``keys``) and every model of infinite key are left last, at ``inf``."""
    keys = np.array(keys, dtype=float)
    if own is not None:
        keys[own] = np.inf
    order = np.argsort(keys, kind="stable")
    if anchors == 0:
        return keys
    pool = order[:POOL]
    near = pool[:anchors]
    spread = np.mean(((whole[pool][:, None, :] - whole[near][None]) ** 2).sum(axis=2), axis=1)
    blended = (1.0 - weight) * keys[pool] + weight * spread
    # The first answer stays first; the rest of the pool by the blend; the others after.
    rest = pool[1:][np.argsort(blended[1:], kind="stable")]
    ranked = np.concatenate([pool[:1], rest, order[POOL:]])
    result = np.empty(len(keys))
    result[ranked] = np.arange(len(keys), dtype=float)
    result[~np.isfinite(keys)] = np.inf
    return result


def round_one_ranking(keys: np.ndarray, whole: np.ndarray) -> np.ndarray:
    """Round 1's choice, the service's scan order from the sixteenth to the thirty-seventh
    session (the reference of ``scan_first_select.py`` and ``scan_frame_select.py``): one
    query's places ``(models,)``, lower first (``inf`` where ``keys`` is): the least key
    first, the rest of the ``POOL`` least keys by ``(1 - 0.75) key + 0.75 |x - x_first|^2``,
    the others after them by key (``expanded_order``'s ``m1 w0.75``)."""
    return expanded_order(keys, whole, None, 1, SHIPPED_WEIGHT)


def round_one_positions(queries: np.ndarray, entries: np.ndarray, owners: np.ndarray,
                        left_out: np.ndarray, whole: np.ndarray) -> np.ndarray:
    """``round_one_ranking`` of each query (``(q, models)``) over a whole catalogue, its
    ``left_out`` model (``core.rank.hubness.scan_hub_keys``'s) last."""
    keys = scan_hub_keys(queries, entries, owners, left_out)
    left_out = np.asarray(left_out)
    rows = np.flatnonzero(left_out >= 0)
    keys[rows, left_out[rows]] = np.inf
    return np.array([round_one_ranking(row, whole) for row in keys])


def candidate_scores(catalogue: Catalogue, kind: str
                     ) -> dict[str, tuple[dict[str, float], np.ndarray]]:
    """Every candidate's scores and per-query average precision for the ``kind`` queries."""
    own = catalogue.query_models[kind]
    keys = scan_hub_keys(catalogue.queries[kind], catalogue.entries, catalogue.owners, own)
    whole = whole_rows(catalogue)
    results = {}
    for name, (anchors, weight) in candidates().items():
        ranked = np.array([expanded_order(row, whole, int(model), anchors, weight)
                           for row, model in zip(keys, own, strict=True)])
        results[name] = ranked_scores(catalogue, kind, ranked)
    return results


def score_all(root: Path, descriptor: str, sources: tuple[str, ...], kind: str
              ) -> tuple[Table, dict[str, dict[str, np.ndarray]]]:
    """Every candidate on every source for the ``kind`` queries."""
    return tabulate(sources, lambda source: candidate_scores(
        source_catalogue(root, source, descriptor, kinds=(kind,)), kind))


def second_round_candidates() -> dict[str, tuple[str, float]]:
    """Round 2's candidate name -> (nearness, weight), in its tie order (``shipped``, the
    plain nearness at ``w`` 0.75, first)."""
    grid: dict[str, tuple[str, float]] = {SHIPPED: ("plain", SHIPPED_WEIGHT)}
    for nearness in NEARNESS:
        for weight in ROUND_2_WEIGHTS[nearness]:
            if (nearness, weight) != ("plain", SHIPPED_WEIGHT):
                grid[f"{nearness} w{weight:g}"] = (nearness, weight)
    return grid


def anchored_order(keys: np.ndarray, whole: np.ndarray, radii: np.ndarray, own: int,
                   nearness: str, weight: float) -> np.ndarray:
    """Ranking positions ``(models,)`` (lower first) of one query: the first answer by
    ``keys`` first, the rest of the pool by ``(1 - weight) keys + weight c(p)``, ``c`` the
    ``nearness`` to the first answer's whole descriptor (``whole`` ``(models, d)``;
    ``radii`` ``(models,)`` the shape-mode ``r_10`` with ``own`` left out), the other models
    after the pool by ``keys``; ``own`` (the scanned model) last."""
    keys = keys.copy()
    keys[own] = np.inf
    order = np.argsort(keys, kind="stable")
    # The scanned model is in no pool, even of a source smaller than the pool (capod's
    # non-rigid classes, 30 models): its vector must not enter the neighbourhoods.
    pool = order[:POOL][np.isfinite(keys[order[:POOL]])]
    anchor, rest = pool[0], pool[1:]
    squared = np.sum((whole[rest] - whole[anchor]) ** 2, axis=1)
    if nearness == "service":
        near = pool_keys(whole[anchor], whole[rest], hub_keys(squared, radii[rest]))
    elif nearness == "hub":
        near = hub_keys(squared, radii[rest])
    else:
        near = squared
    blended = (1.0 - weight) * keys[rest] + weight * near
    ranked = np.concatenate([pool[:1], rest[np.argsort(blended, kind="stable")],
                             order[len(pool):]])
    result = np.empty(len(keys))
    result[ranked] = np.arange(len(keys), dtype=float)
    result[own] = np.inf
    return result


def second_round_scores(catalogue: Catalogue, kind: str
                        ) -> dict[str, tuple[dict[str, float], np.ndarray]]:
    """Round 2's candidates' scores and per-query average precision for the ``kind``
    queries."""
    own = catalogue.query_models[kind]
    keys = scan_hub_keys(catalogue.queries[kind], catalogue.entries, catalogue.owners, own)
    whole = whole_rows(catalogue).astype(np.float64)
    models = np.arange(len(catalogue.models))
    radii = neighbourhood_radii(whole, HUB_NEIGHBOURS, exclude=own[:, None] == models[None])
    results = {}
    for name, (nearness, weight) in second_round_candidates().items():
        ranked = np.array([
            anchored_order(row, whole, radii[query], int(model), nearness, weight)
            for query, (row, model) in enumerate(zip(keys, own, strict=True))])
        results[name] = ranked_scores(catalogue, kind, ranked)
    return results


def second_round_all(root: Path, descriptor: str, sources: tuple[str, ...], kind: str
                     ) -> tuple[Table, dict[str, dict[str, np.ndarray]]]:
    """Round 2's candidates on every source for the ``kind`` queries."""
    return tabulate(sources, lambda source: second_round_scores(
        source_catalogue(root, source, descriptor, kinds=(kind,)), kind))


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    # ``--round 2`` anywhere on the line; study_arguments parses the rest.
    chosen_round = argv[argv.index("--round") + 1] if "--round" in argv else "1"
    if "--round" in argv:
        del argv[argv.index("--round"):argv.index("--round") + 2]
    args = study_arguments(__doc__, argv)
    if chosen_round == "2":
        record = run_study(args.out, second_round_all, list(second_round_candidates()),
                           SHIPPED)
    else:
        record = run_study(args.out, score_all, list(candidates()), SHIPPED)
    if args.json:
        args.json.write_text(json.dumps(record, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
