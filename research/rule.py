"""The rule every study is decided by, written before any score of a study is seen.

1. A source's score is its mAP, each model a query against the rest of its source (PSB
   conventions, ``core.evaluation.metrics``), ranked in the search service's order
   (``service_order``: the hub discount, the k-reciprocal re-rank with its first answer kept);
   capod's articulated classes are scored apart as ``capod-nonrigid``, not one of the rule's
   sources.
2. The choice: the candidate with the highest mean over the rule's sources, each weighing
   the same; a candidate within ``TIE`` (0.002) of the best goes before it when it comes
   first in the study's tie order (the reference first, then the grid's order).
3. Leave one source out: for each source, the candidate the rule picks from the other sources
   alone, scored on it; their mean against the reference's, with a 95 % bootstrap over
   queries, paired (the same queries drawn for both), per source then averaged.
4. Tests. A candidate ships only if (1) that left-out mean is above the reference's by more
   than ``TIE`` with the interval's lower end above zero, and (2) the four third-party
   libraries searched as one catalogue, scored by kind (``CATALOGUE``, ``KIND_OF``; one
   vocabulary fitted on the other sources), keep mAP not below the reference's and NN not
   below it by more than ``NN_SLACK``. (3) Fixed, on an extraction no step has seen
   (``research.extract --seed``, ``--confirm``): its mean above the reference's by more than
   ``TIE`` with the paired interval above zero, and test 2 there. A study's own docstring
   may add tests (a library no choice saw, the ``bendable`` family, copies of one part).
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Callable
from pathlib import Path

import numpy as np

from core.evaluation.metrics import average_precision, ranked_relevance, score_rankings
from core.rank.hubness import HUB_NEIGHBOURS, HUB_WEIGHT, hub_discounted_keys
from core.rank.reciprocal import (
    BLEND,
    EXPANSION,
    RECIPROCAL_NEIGHBOURS,
    reciprocal_keys,
    rescaled_rows,
)
from core.settings import DescriptorSettings
from research.study import Study

__all__ = [
    "CATALOGUE", "KIND_OF", "NN_SLACK", "TIE", "bootstrap", "catalogue_holds", "choose",
    "command", "loso", "run", "scores", "service_order",
]

TIE = 0.002
NN_SLACK = 0.01
#: The third-party libraries of test 2, searched as one catalogue.
CATALOGUE = ("madcad", "gearworks", "vslot", "mcad")
#: Library kinds that are one kind of part (decided from what each part is, not from a
#: score): bd-vslot's sealed 6xx bearings are deep-groove ball bearings, pymadcad's "flat
#: head" screws countersunk, MCAD's bolts the screws of the same heads, and both gear
#: libraries make spur, helical and bevel gears.
KIND_OF = {member: kind for kind, members in {
    "ball_bearing": ("madcad/ball_bearing", "mcad/ball_bearing", "vslot/bearing"),
    "hex_head_screw": ("madcad/screw_hex_head", "mcad/hex_bolt"),
    "socket_head_screw": ("madcad/screw_socket_head", "mcad/cap_bolt"),
    "countersunk_screw": ("madcad/screw_flat_head", "mcad/countersunk_bolt"),
    "spur_gear": ("gearworks/spur_gear", "mcad/spur_gear"),
    "helical_gear": ("gearworks/helical_gear", "mcad/helical_gear"),
    "bevel_gear": ("gearworks/bevel_gear", "mcad/bevel_gear"),
}.items() for member in members}

#: Scores (``map``, ``nn``, ...) per candidate, per scored source.
Table = dict[str, dict[str, dict[str, float]]]
#: Each query's average precision per candidate, per scored source.
Queries = dict[str, dict[str, np.ndarray]]


def service_order(rows: np.ndarray) -> np.ndarray:
    """Ranking keys ``(m, m)``, lower first, of every model (row) for every other, in the
    search service's order: the k-reciprocal re-rank blended with the hub discount's keys
    (each query left out of the radii), that discount's first answer kept."""
    discount = hub_discounted_keys(rows, rows, HUB_NEIGHBOURS, HUB_WEIGHT,
                                   exclude=np.eye(len(rows), dtype=bool))
    return reciprocal_keys(rows, rescaled_rows(discount), RECIPROCAL_NEIGHBOURS, EXPANSION,
                           BLEND)


def scores(keys: np.ndarray, labels: list[str] | tuple[str, ...]
           ) -> tuple[dict[str, float], np.ndarray]:
    """Scores of ranking keys ``(m, m)`` (each model a query, itself left out) and each
    query's average precision (queries with a relevant model)."""
    relevance = ranked_relevance(keys, labels, labels, np.eye(len(labels), dtype=bool))
    return score_rankings(relevance), np.array([average_precision(r) for r in relevance
                                                if r.any()])


def choose(table: Table, pool: list[str], over: list[str]) -> str:
    """Clause 2: the best mean mAP over ``over``; within ``TIE`` of it, the earlier in
    ``pool``."""
    means = {c: float(np.mean([table[c][s]["map"] for s in over])) for c in pool}
    best = max(means.values())
    return next(c for c in pool if means[c] >= best - TIE)


def loso(table: Table, pool: list[str], sources: list[str]) -> dict[str, str]:
    """Clause 3: per source, the candidate ``choose`` picks on the others."""
    return {s: choose(table, pool, [o for o in sources if o != s]) for s in sources}


def bootstrap(a: dict[str, np.ndarray], b: dict[str, np.ndarray], over: list[str],
              draws: int = 2000) -> tuple[float, float, float]:
    """The mean over ``over`` of (a - b) mAP per source, and its 95 % interval by a paired
    bootstrap over each source's queries (seeded)."""
    rng = np.random.default_rng(0)
    diffs = np.zeros(draws)
    for s in over:
        delta = a[s] - b[s]
        picks = rng.integers(0, len(delta), size=(draws, len(delta)))
        diffs += delta[picks].mean(axis=1) / len(over)
    low, high = np.percentile(diffs, [2.5, 97.5])
    return float(np.mean([np.mean(a[s] - b[s]) for s in over])), float(low), float(high)


def catalogue_holds(chosen: dict[str, float], reference: dict[str, float]) -> bool:
    """Test 2: mAP not below the reference's, NN not below it by more than ``NN_SLACK``."""
    return chosen["map"] >= reference["map"] and chosen["nn"] >= reference["nn"] - NN_SLACK


def _catalogue(study: Study, settings: DescriptorSettings) -> dict[str, float]:
    """Test 2's scores of one candidate: the ``CATALOGUE`` libraries as one catalogue, by
    kind, in the service's order."""
    rows = study.rows(settings, CATALOGUE, study.pooled_local(settings, CATALOGUE))
    by_name = {source.name: source for source in study.sources}
    kinds = [KIND_OF.get(f"{name}/{label}", f"{name}/{label}")
             for name in CATALOGUE for label in by_name[name].labels]
    return scores(service_order(np.vstack([rows[name] for name in CATALOGUE])), kinds)[0]


def _print_table(table: Table, mean: dict[str, float], count: int) -> None:
    names = list(next(iter(table.values())))
    print(f"\n| candidate | mean of {count} | " + " | ".join(names) + " |")
    print("|---|---|" + "---|" * len(names))
    for c in table:
        cells = [f"{table[c][s]['map']:.3f} / {table[c][s]['nn']:.3f}" for s in names]
        print(f"| {c} | {mean[c]:.4f} | " + " | ".join(cells) + " |")


def run(study: Study, candidates: dict[str, DescriptorSettings], reference: str,
        title: str, confirm: str | None = None, json_path: Path | None = None
        ) -> dict[str, object]:
    """Score every candidate (``reference`` among them; the dict's order is the tie order)
    on every scored source and on test 2's catalogue, then decide: the rule and tests 1 and
    2, or with ``confirm`` test 3 of that fixed candidate. Prints every figure, writes them
    to ``json_path``, returns them."""
    study.require(CATALOGUE)
    if confirm:
        candidates = {reference: candidates[reference], confirm: candidates[confirm]}
    table: Table = {}
    queries: Queries = {}
    labels = study.scored
    for name, settings in candidates.items():
        for source, rows in study.rows(settings).items():
            table.setdefault(name, {})[source], queries.setdefault(name, {})[source] = scores(
                service_order(rows), labels[source])
        print(f"scored {name}", flush=True)
    catalogue = {name: _catalogue(study, settings) for name, settings in candidates.items()}
    sources = study.names
    mean = {c: float(np.mean([table[c][s]["map"] for s in sources])) for c in table}
    _print_table(table, mean, len(sources))
    report: dict[str, object] = {"title": title, "table": table, "mean": mean,
                                 "catalogue_by_kind": catalogue}
    chosen = confirm or choose(table, list(table), sources)
    if confirm:
        point, low, high = bootstrap(queries[confirm], queries[reference], sources)
        first = point > TIE and low > 0
        print(f"\ntest 3, {confirm} fixed - {reference}: {point:+.4f} "
              f"(95 % {low:+.4f} .. {high:+.4f}): {first}")
    else:
        left_out = loso(table, list(table), sources)
        loso_mean = float(np.mean([table[c][s]["map"] for s, c in left_out.items()]))
        point, low, high = bootstrap({s: queries[c][s] for s, c in left_out.items()},
                                     queries[reference], sources)
        first = loso_mean > mean[reference] + TIE and low > 0
        print(f"\n{title}: the rule's choice over the {len(sources)}: {chosen}")
        print(f"| source left out | choice without it | mAP / NN | {reference} |")
        print("|---|---|---|---|")
        for s, c in left_out.items():
            print(f"| {s} | {c} | {table[c][s]['map']:.3f} / {table[c][s]['nn']:.3f} | "
                  f"{table[reference][s]['map']:.3f} / {table[reference][s]['nn']:.3f} |")
        print(f"left out {loso_mean:.4f} against {mean[reference]:.4f}: {point:+.4f} "
              f"(95 % {low:+.4f} .. {high:+.4f}); test 1: {first}")
        report.update(loso=left_out, loso_mean=loso_mean)
    second = catalogue_holds(catalogue[chosen], catalogue[reference])
    for name in dict.fromkeys((reference, chosen)):
        print(f"one catalogue by kind, {name}: NN {catalogue[name]['nn']:.3f}, "
              f"mAP {catalogue[name]['map']:.3f}")
    holds = chosen != reference and first and second
    print(f"test 2: {second}; {'test 3' if confirm else 'tests 1 and 2'} hold: {holds}")
    report.update(chosen=chosen, difference=[point, low, high], holds=holds)
    if json_path:
        json_path.write_text(json.dumps(report, indent=1))
    return report


def command(doc: str, argv: list[str] | None,
            extra: Callable[[argparse.ArgumentParser], object] | None = None
            ) -> tuple[argparse.Namespace, Study | None]:
    """A study's command line: ``OUT`` (an extraction, ``research.extract``), ``--json``,
    ``--confirm CANDIDATE`` (test 3 on another extraction) and what ``extra`` adds; the study
    of ``OUT`` (None when ``OUT`` is not given: a study's checks need none)."""
    parser = argparse.ArgumentParser(description=doc.splitlines()[0])
    parser.add_argument("out", type=Path, nargs="?")
    parser.add_argument("--json", type=Path)
    parser.add_argument("--confirm", help="test 3: this candidate, fixed, on this extraction")
    if extra:
        extra(parser)
    args = parser.parse_args(argv)
    return args, Study(args.out) if args.out else None
