"""Scan mode: should a scan also be described as virtual views of its own points?

Why it is asked: on held-out standard parts in scan mode, three views merged into one cloud
score below a single view (NN 0.622 / mAP 0.573 against 0.711 / 0.659): a scanner's user who
takes more views gets worse answers. Scan mode's first answer decides most of its order (the
rest is that answer's shape-mode order, ``core.rank.scan_order``), and it is chosen by each
model's best entry, the model whole or one of three virtual views of it. A single view meets
a catalogue view; a merged scan, most of the part with holes where no view reached, meets
neither. Candidate: scan mode describes the query also as ``n`` virtual views of its own
points (``core.views.virtual_views``, the catalogue's fixed directions, in the query's own
frame) and keys each model by its least over the scan and its views. A view cut from a
merged scan looks like one view of the part, which the catalogue's views meet; a view cut
from a single view is most of it again. What it risks: more rows per query, more chances
for a wrong model's entry to come close (hubness), and ``n`` more describes per scan query.

Candidates (the tie order): ``scan`` (the reference: the scan alone, as today) and ``own3``
(the scan and 3 views of it).

Score: a source's mAP over its scans as queries, each model's merged three-view scan
(``multi+sor``) and its single view (``single+sor``) pooled, each against the rest of its
source (leave-one-out) in scan mode's order for 10 results (``views3+hub``), the catalogue
each model whole and as 3 virtual views. The sources: the six third-party libraries
``madcad``, ``gearworks``, ``vslot``, ``mcad``, ``freecad``, ``cqparts`` and CAPOD's rigid
classes (``capod``), 3 models a kind (``load_dataset``'s seeded subset), one draw of
rotations and scans (``--rotation-seed 3``). Ours (``generated``, ``bendable``) and CAPOD's
articulated classes are reported, never voting (ours only when time allows: not described
by default). Amended before any score was read: 5 models a kind and ours described by
default were the first text; at 25 s a model on this 2-core machine both draws would not
have finished in the session.

The rule: ``research.rule``'s clause 2 (``choose``) and clause 3 (``loso``, ``bootstrap``).
It ships only if (1) the left-out mean is above the reference's by more than ``TIE`` with
the interval above zero; (2) clean queries in scan mode (each model whole, as a scan query)
keep their mean mAP over the voting sources within 0.01 of the reference's; (3) on a second
draw of every rotation and scan (``--rotation-seed 5``), fixed, its mean is above the
reference's by more than ``TIE`` with the interval above zero; (4) after adoption, BOSL2 (no
choice saw it) in scan mode, merged and single: mean mAP not below the reference's by more
than 0.01. Its cost (the describe of a scan query, and a scan search at 10^5 models with four
query rows) is measured by ``bench/`` and reported beside the verdict.

    python -m core.evaluation.sources /work/tuning --sources madcad gearworks vslot mcad \\
        freecad cqparts capod generated bendable
    python -m research.studies.scan_own_views describe /work/tuning /work/scan-own --seed 3
    python -m research.studies.scan_own_views decide /work/scan-own --seed 3
    python -m research.studies.scan_own_views describe /work/tuning /work/scan-own --seed 5
    python -m research.studies.scan_own_views decide /work/scan-own --seed 5 --confirm own3

**Record** (2026-12-07, 2-core machine; 192 models of the seven sources a draw, each
described whole, as 3 views, as a merged and a single scan, and as 3 own views of each
query). Seed 3: mean of seven, the scans pooled, ``scan`` 0.7072 and ``own3`` 0.7126
(merged 0.7249 -> 0.7299, single 0.6894 -> 0.6952), the rule's choice ``own3``, but left
out **-0.0094 (95 % -0.0328 .. +0.0130)**: test 1 fails; clean queries 0.8628 -> 0.8300,
test 2 fails too (FreeCAD 0.932 -> 0.777, CAPOD 1.000 -> 0.942); BOSL2 0.751 -> 0.693.
Seed 5 (run for the record, not needed for the verdict): 0.7269 -> 0.7267, the rule keeps
``scan``, left out -0.0145 (-0.0320 .. +0.0020). **Declined**: a scan's own views add as many
wrong near entries as right ones. On these draws merged scans already score above single
views in the mean (0.725 against 0.689; 0.751 against 0.703); MCAD is the source where they
do not (0.463 against 0.539).
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

#: The sources that vote, and those reported beside them.
VOTING = ("madcad", "gearworks", "vslot", "mcad", "freecad", "cqparts", "capod")
#: ``bosl2`` is test 4's judge (``describe /work/tuning-bosl2 OUT --sources bosl2``).
REPORTED = ("generated", "bendable", "capod-nonrigid", "bosl2")
NONRIGID_CAPOD = ("Dog", "Hand", "Horse", "Human", "Spider")
PER_CLASS = 3
VIEWS = 3
#: Candidate -> how many of the query's own views join it.
CANDIDATES = {"scan": 0, "own3": 3}
SCANS = ("multi+sor", "single+sor")
CLEAN_SLACK = 0.01


def describe(tuning: Path, out: Path, seed: int, sources: list[str]) -> None:
    """Describe every source's catalogue, scans and the scans' own views (cached)."""
    for source in sources:
        folder = "capod" if source == "capod-nonrigid" else source
        describe_source(tuning / folder, out / f"seed{seed}" / folder, PER_CLASS, VIEWS,
                        query_kinds=("clean", *SCANS), variants=("default",),
                        rotation_seed=seed, own_views=max(CANDIDATES.values()))


def _source_rows(record_dir: Path, keep: tuple[str, ...] | None, drop: tuple[str, ...]
                 ) -> tuple[list[str], list[str], dict[str, np.ndarray]]:
    """The models (sorted), their labels and every described vector by ``kind|model``."""
    record = json.loads((record_dir / "scan_retrieval.json").read_text())
    vectors = np.load(record_dir / "scan_retrieval_descriptors.npz")
    rows = {f"{key.split('|')[0]}|{key.split('|')[2]}": vectors[key] for key in vectors.files
            if key.split("|")[1] == "default"}
    dataset = load_dataset(record["dataset"], record["per_class"])
    labels = {m.name: m.label for m in dataset.models}
    names = [n for n in sorted(record["scored_models"])
             if (keep is None or labels[n] in keep) and labels[n] not in drop]
    return names, [labels[n] for n in names], rows


def query_precisions(names: list[str], labels: list[str], rows: dict[str, np.ndarray],
                     kind: str, own: int) -> np.ndarray:
    """Each ``kind`` query's average precision in scan mode's order, with ``own`` views of
    it (0: the scan alone)."""
    entries, owners = [], []
    for index, name in enumerate(names):
        for entry in ["clean", *(f"view{i}of{VIEWS}" for i in range(VIEWS))]:
            if f"{entry}|{name}" in rows:
                entries.append(rows[f"{entry}|{name}"])
                owners.append(index)
    whole = np.array([rows[f"clean|{name}"] for name in names])
    queries = [n for n in names if f"{kind}|{n}" in rows]
    query_rows = [rows[f"{kind}|{n}"] for n in queries]
    query_of = list(range(len(queries)))
    for number, name in enumerate(queries):
        for i in range(own):
            key = f"{kind}@qv{i}of{own}|{name}"
            if key in rows:
                query_rows.append(rows[key])
                query_of.append(number)
    position = {name: index for index, name in enumerate(names)}
    left_out = np.array([position[q] for q in queries])
    keys = scan_mode_positions(np.array(query_rows), np.array(entries), np.array(owners),
                               left_out, whole, query_of=np.array(query_of))
    label_of = dict(zip(names, labels, strict=True))
    exclude = np.array([[q == d for d in names] for q in queries])
    relevance = ranked_relevance(keys, [label_of[q] for q in queries], labels, exclude)
    return np.array([average_precision(r) for r in relevance if r.any()])


def decide(out: Path, seed: int, confirm: str | None) -> dict[str, object]:
    """Score every candidate on every source, apply the rule, print and return it all."""
    base = out / f"seed{seed}"
    table: dict[str, dict[str, dict[str, float]]] = {}
    queries: dict[str, dict[str, np.ndarray]] = {}
    by_kind: dict[str, dict[str, dict[str, float]]] = {}
    sources = [s for s in (*VOTING, *REPORTED)
               if (base / ("capod" if s == "capod-nonrigid" else s)).exists()]
    for source in sources:
        folder = "capod" if source == "capod-nonrigid" else source
        keep = NONRIGID_CAPOD if source == "capod-nonrigid" else None
        drop = NONRIGID_CAPOD if source == "capod" else ()
        names, labels, rows = _source_rows(base / folder, keep, drop)
        for candidate, own in CANDIDATES.items():
            precisions = {kind: query_precisions(names, labels, rows, kind, own)
                          for kind in (*SCANS, "clean")}
            pooled = np.concatenate([precisions[k] for k in SCANS])
            queries.setdefault(candidate, {})[source] = pooled
            table.setdefault(candidate, {})[source] = {"map": float(pooled.mean())}
            by_kind.setdefault(candidate, {})[source] = {
                k: float(v.mean()) for k, v in precisions.items()}
    voting = [s for s in VOTING if s in sources]
    pool = list(CANDIDATES)
    print("\n| candidate | source | scans (merged and single) | merged | single | clean |")
    print("|---|---|---|---|---|---|")
    for c in pool:
        for s in sources:
            k = by_kind[c][s]
            print(f"| {c} | {s}{'' if s in voting else ' (not voting)'} | "
                  f"{table[c][s]['map']:.3f} | {k['multi+sor']:.3f} | {k['single+sor']:.3f} | "
                  f"{k['clean']:.3f} |")
    mean = {c: float(np.mean([table[c][s]["map"] for s in voting])) for c in pool}
    merged = {c: float(np.mean([by_kind[c][s]["multi+sor"] for s in voting])) for c in pool}
    single = {c: float(np.mean([by_kind[c][s]["single+sor"] for s in voting])) for c in pool}
    clean = {c: float(np.mean([by_kind[c][s]["clean"] for s in voting])) for c in pool}
    for c in pool:
        print(f"{c}: mean of {len(voting)} {mean[c]:.4f} (merged {merged[c]:.4f}, single "
              f"{single[c]:.4f}, clean {clean[c]:.4f})")
    reference = pool[0]
    report: dict[str, object] = {"seed": seed, "table": table, "by_kind": by_kind,
                                 "mean": mean, "voting": voting}
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
    print(f"the rule's choice: {chosen}; left out {loso_mean:.4f} against "
          f"{mean[reference]:.4f}: {point:+.4f} (95 % {low:+.4f} .. {high:+.4f})")
    print(f"test 1: {first}; test 2 (clean {clean[chosen]:.4f} against "
          f"{clean[reference]:.4f}): {second}")
    report.update(chosen=chosen, loso=left_out, loso_mean=loso_mean,
                  difference=[point, low, high], holds=chosen != reference and first and second)
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
    rule.add_argument("--json", type=Path)
    args = parser.parse_args(argv)
    if args.command == "describe":
        describe(args.tuning, args.out, args.seed, args.sources)
        return 0
    report = decide(args.out, args.seed, args.confirm)
    if args.json:
        args.json.write_text(json.dumps(report, indent=1, default=str))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
