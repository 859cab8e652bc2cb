"""Scan mode: should each part also be indexed as merged pairs of its virtual views?

Why it is asked: on held-out standard parts in scan mode, three views merged into one cloud
score below a single view (NN 0.622 / mAP 0.573 against 0.711 / 0.659). The catalogue holds
each part whole and as 3 virtual views; a single view meets a view, but a merged scan (most
of the part, with holes where no view reached) meets neither. Describing the scan as views
of its own was declined (``scan_own_views``, left out -0.0094). Candidate here: index each
part also as the union of two of its virtual views (``merge<ij>of3``, what two viewpoints
see together), so that a merged scan meets an entry of its own coverage. What it risks:
more entries per model, more near entries of wrong models for a single view (hubness), and
describe time at ingest.

Candidates (the tie order): ``views`` (the reference: whole and 3 views, as today), ``pair``
(and ``merge01of3``), ``pairs`` (and all three pairs ``merge01of3``, ``merge02of3``,
``merge12of3``).

Score, sources and draws as ``scan_own_views``: a source's mAP over its merged three-view
scans (``multi+sor``) and single views (``single+sor``) pooled, each against the rest of its
source in scan mode's order (``views3+hub``, the catalogue's entries per candidate); the
seven voting sources (``madcad``, ``gearworks``, ``vslot``, ``mcad``, ``freecad``,
``cqparts``, CAPOD's rigid classes), 3 models a kind, ``--rotation-seed 3``; ours and CAPOD's
articulated classes reported; BOSL2 reported (test 4's judge).

The rule: ``research.rule``'s ``choose``, ``loso`` and ``bootstrap``. It ships only if (1)
the left-out mean is above the reference's by more than ``TIE`` with the interval above
zero; (2) clean queries in scan mode keep their mean mAP over the voting sources within 0.01
of the reference's; (3) fixed, on the second draw (``--rotation-seed 5``), its mean is above
the reference's by more than ``TIE`` with the interval above zero; (4) BOSL2, merged and
single pooled, not below the reference's by more than 0.01; (5) a part's describe time at
ingest (whole, views and pairs: the mean seconds of the Laplacian, eigensolve and
descriptor of each entry kind, measured in the same run) at most 1.5x the reference's.

    python -m research.studies.scan_view_pairs describe /work/tuning /work/scan-own --seed 3
    python -m research.studies.scan_view_pairs describe /work/tuning-bosl2 /work/scan-own \\
        --seed 3 --sources bosl2
    python -m research.studies.scan_view_pairs decide /work/scan-own --seed 3
    python -m research.studies.scan_view_pairs describe /work/tuning /work/scan-own --seed 5
    python -m research.studies.scan_view_pairs decide /work/scan-own --seed 5 --confirm pair

(``/work/scan-own`` is ``scan_own_views``' folder: its cached eigenpairs are read again.)

**Record, round 1** (2026-12-07, seed 3, 192 models of the seven sources): ``views`` 0.7072
(merged 0.7249, single 0.6894, clean 0.8628), ``pair`` 0.7165 at 1.21x the describe time,
``pairs`` 0.7472 (merged 0.7944, single 0.7000, clean 0.8573) at 1.63x; the rule's choice
``pairs``, left out **+0.0400 (95 % +0.0151 .. +0.0659)**: tests 1 and 2 hold, test 5 fails
(1.63x the describe time, over 1.5x). Not shipped by its cost.

**Round 2** (written after round 1's figures were read, disclosed as such; before any score
of its candidate): the pairs *instead of* the single views, ``pairs-only`` (whole and the
three pairs: four entries, as today), at about today's describe time. Reference ``views``;
the same score, sources, draws and tests 1-4 (test 3 on seed 5, fixed); test 5: the
evaluation's describe time at most 1.5x and, after adoption, the service's describe of a
catalogue part (``core.pipeline.describe`` with its views) at most 1.5x today's, median over
parts (``bench/``).

    python -m research.studies.scan_view_pairs decide /work/scan-own --seed 3 --round 2
    python -m research.studies.scan_view_pairs decide /work/scan-own --seed 5 --round 2 \
        --confirm pairs-only

**Record, round 2, and the rest** (2026-12-07): ``pairs-only`` 0.7041 against 0.7072 (merged
0.8036, single views 0.6046: a single view needs a single-view entry), left out **-0.0139
(95 % -0.0327 .. +0.0041)**: declined. For the record, round 1's ``pairs`` fixed on seed 5:
0.7269 -> 0.7550, **+0.0280 (+0.0113 .. +0.0459)**, merged 0.751 -> 0.798, at 1.61x; and on
BOSL2 (test 4, no choice saw it) it falls, 0.751 -> 0.719 (merged 0.778 -> 0.740, single
0.724 -> 0.698): declined by its cost and by the judge alike.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from core.evaluation.dataset import load_dataset
from core.evaluation.metrics import average_precision, ranked_relevance
from core.evaluation.scan_retrieval import run as describe_source
from core.rank.scan_order import scan_mode_positions
from research.rule import TIE, bootstrap, choose, loso

VOTING = ("madcad", "gearworks", "vslot", "mcad", "freecad", "cqparts", "capod")
REPORTED = ("generated", "bendable", "capod-nonrigid", "bosl2")
NONRIGID_CAPOD = ("Dog", "Hand", "Horse", "Human", "Spider")
PER_CLASS = 3
VIEWS = 3
PAIRS = ("merge01of3", "merge02of3", "merge12of3")
#: Candidate -> its catalogue entries besides the whole model.
CANDIDATES = {
    "views": tuple(f"view{i}of{VIEWS}" for i in range(VIEWS)),
    "pair": (*(f"view{i}of{VIEWS}" for i in range(VIEWS)), PAIRS[0]),
    "pairs": (*(f"view{i}of{VIEWS}" for i in range(VIEWS)), *PAIRS),
}
#: Round 2's candidates (after round 1's figures): the pairs in place of the single views.
ROUND_2 = {
    "views": CANDIDATES["views"],
    "pairs-only": PAIRS,
}
SCANS = ("multi+sor", "single+sor")
CLEAN_SLACK = 0.01
JUDGE_SLACK = 0.01
COST_LIMIT = 1.5


def describe(tuning: Path, out: Path, seed: int, sources: list[str]) -> None:
    """Describe every source's catalogue (views and pairs) and its scans (cached)."""
    for source in sources:
        describe_source(tuning / source, out / f"seed{seed}" / source, PER_CLASS, VIEWS,
                        query_kinds=("clean", *SCANS), variants=("default",),
                        rotation_seed=seed, merged=PAIRS)


def _source(record_dir: Path, keep: tuple[str, ...] | None, drop: tuple[str, ...]
            ) -> tuple[list[str], list[str], dict[str, np.ndarray], dict[str, float]]:
    """The models (sorted), their labels, every vector by ``kind|model`` and each kind's mean
    describe seconds (Laplacian, eigensolve and descriptor)."""
    record = json.loads((record_dir / "scan_retrieval.json").read_text())
    vectors = np.load(record_dir / "scan_retrieval_descriptors.npz")
    rows = {f"{key.split('|')[0]}|{key.split('|')[2]}": vectors[key] for key in vectors.files
            if key.split("|")[1] == "default"}
    labels = {m.name: m.label for m in load_dataset(record["dataset"],
                                                     record["per_class"]).models}
    names = [n for n in sorted(record["scored_models"])
             if (keep is None or labels[n] in keep) and labels[n] not in drop]
    seconds = {kind: sum(v[stage] for stage in ("laplacian", "eigensolve", "descriptor"))
               for kind, v in record["seconds"].items()}
    return names, [labels[n] for n in names], rows, seconds


def query_precisions(names: list[str], labels: list[str], rows: dict[str, np.ndarray],
                     kind: str, entry_kinds: tuple[str, ...]) -> np.ndarray:
    """Each ``kind`` query's average precision in scan mode's order, the catalogue each
    model whole and its ``entry_kinds``."""
    entries, owners = [], []
    for index, name in enumerate(names):
        for entry in ("clean", *entry_kinds):
            if f"{entry}|{name}" in rows:
                entries.append(rows[f"{entry}|{name}"])
                owners.append(index)
    whole = np.array([rows[f"clean|{name}"] for name in names])
    queries = [n for n in names if f"{kind}|{n}" in rows]
    position = {name: index for index, name in enumerate(names)}
    keys = scan_mode_positions(np.array([rows[f"{kind}|{n}"] for n in queries]),
                               np.array(entries), np.array(owners),
                               np.array([position[q] for q in queries]), whole)
    label_of = dict(zip(names, labels, strict=True))
    exclude = np.array([[q == d for d in names] for q in queries])
    relevance = ranked_relevance(keys, [label_of[q] for q in queries], labels, exclude)
    return np.array([average_precision(r) for r in relevance if r.any()])


def decide(out: Path, seed: int, confirm: str | None, candidates: dict[str, tuple[str, ...]]
           = CANDIDATES) -> dict[str, object]:
    """Score every candidate on every source, apply the rule, print and return it all."""
    base = out / f"seed{seed}"
    table: dict[str, dict[str, dict[str, float]]] = {}
    queries: dict[str, dict[str, np.ndarray]] = {}
    by_kind: dict[str, dict[str, dict[str, float]]] = {}
    cost: dict[str, list[float]] = {c: [] for c in candidates}
    sources = [s for s in (*VOTING, *REPORTED)
               if (base / ("capod" if s == "capod-nonrigid" else s)).exists()]
    for source in sources:
        folder = "capod" if source == "capod-nonrigid" else source
        keep = NONRIGID_CAPOD if source == "capod-nonrigid" else None
        drop = NONRIGID_CAPOD if source == "capod" else ()
        names, labels, rows, seconds = _source(base / folder, keep, drop)
        for candidate, entry_kinds in candidates.items():
            precisions = {kind: query_precisions(names, labels, rows, kind, entry_kinds)
                          for kind in (*SCANS, "clean")}
            pooled = np.concatenate([precisions[k] for k in SCANS])
            queries.setdefault(candidate, {})[source] = pooled
            table.setdefault(candidate, {})[source] = {"map": float(pooled.mean())}
            by_kind.setdefault(candidate, {})[source] = {
                k: float(v.mean()) for k, v in precisions.items()}
            if source in VOTING:
                cost[candidate].append(sum(seconds[k] for k in ("clean", *entry_kinds)))
    voting = [s for s in VOTING if s in sources]
    pool = list(candidates)
    print("\n| candidate | source | scans (merged and single) | merged | single | clean |")
    print("|---|---|---|---|---|---|")
    for c in pool:
        for s in sources:
            k = by_kind[c][s]
            print(f"| {c} | {s}{'' if s in voting else ' (not voting)'} | "
                  f"{table[c][s]['map']:.3f} | {k['multi+sor']:.3f} | {k['single+sor']:.3f} | "
                  f"{k['clean']:.3f} |")
    reference = pool[0]
    mean = {c: float(np.mean([table[c][s]["map"] for s in voting])) for c in pool}
    clean = {c: float(np.mean([by_kind[c][s]["clean"] for s in voting])) for c in pool}
    ratio = {c: float(np.mean(cost[c]) / np.mean(cost[reference])) for c in pool}
    for c in pool:
        merged = np.mean([by_kind[c][s]["multi+sor"] for s in voting])
        single = np.mean([by_kind[c][s]["single+sor"] for s in voting])
        print(f"{c}: mean of {len(voting)} {mean[c]:.4f} (merged {merged:.4f}, single "
              f"{single:.4f}, clean {clean[c]:.4f}); describe time {ratio[c]:.2f}x")
    report: dict[str, object] = {"seed": seed, "table": table, "by_kind": by_kind,
                                 "mean": mean, "cost": ratio, "voting": voting}
    if confirm:
        point, low, high = bootstrap(queries[confirm], queries[reference], voting)
        holds = point > TIE and low > 0
        print(f"test 3, {confirm} fixed - {reference}: {point:+.4f} (95 % {low:+.4f} .. "
              f"{high:+.4f}): {holds}")
        report.update(chosen=confirm, difference=[point, low, high], holds=holds)
        return report
    chosen = choose(table, pool, voting)
    left_out = loso(table, pool, voting)
    loso_mean = float(np.mean([table[c][s]["map"] for s, c in left_out.items()]))
    point, low, high = bootstrap({s: queries[c][s] for s, c in left_out.items()},
                                 queries[reference], voting)
    first = loso_mean > mean[reference] + TIE and low > 0
    second = clean[chosen] >= clean[reference] - CLEAN_SLACK
    fifth = ratio[chosen] <= COST_LIMIT
    print(f"the rule's choice: {chosen}; left out {loso_mean:.4f} against "
          f"{mean[reference]:.4f}: {point:+.4f} (95 % {low:+.4f} .. {high:+.4f})")
    print(f"test 1: {first}; test 2 (clean {clean[chosen]:.4f} against "
          f"{clean[reference]:.4f}): {second}; test 5 (cost {ratio[chosen]:.2f}x): {fifth}")
    if "bosl2" in sources:
        judged = table[chosen]["bosl2"]["map"] >= table[reference]["bosl2"]["map"] - JUDGE_SLACK
        print(f"test 4 (BOSL2 {table[chosen]['bosl2']['map']:.4f} against "
              f"{table[reference]['bosl2']['map']:.4f}): {judged}")
    report.update(chosen=chosen, loso=left_out, loso_mean=loso_mean,
                  difference=[point, low, high],
                  holds=chosen != reference and first and second and fifth)
    return report


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    commands = parser.add_subparsers(dest="command", required=True)
    run = commands.add_parser("describe")
    run.add_argument("tuning", type=Path)
    run.add_argument("out", type=Path)
    run.add_argument("--seed", type=int, default=3)
    run.add_argument("--sources", nargs="+", default=list(VOTING))
    rule = commands.add_parser("decide")
    rule.add_argument("out", type=Path)
    rule.add_argument("--seed", type=int, default=3)
    rule.add_argument("--confirm")
    rule.add_argument("--round", type=int, choices=(1, 2), default=1)
    rule.add_argument("--json", type=Path)
    args = parser.parse_args(argv)
    if args.command == "describe":
        describe(args.tuning, args.out, args.seed, args.sources)
        return 0
    report = decide(args.out, args.seed, args.confirm,
                    ROUND_2 if args.round == 2 else CANDIDATES)
    if args.json:
        args.json.write_text(json.dumps(report, indent=1, default=str))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
