"""The point-budget sweep: retrieval quality and ingest seconds against ``max_points``.

The sweep is the ``points-<N>`` variants of ``core.evaluation.variants`` (the default engine
at N points), scored by ``shapesearch eval`` on clean and scanned queries, in one run or in
one run per budget (a budget at a time keeps a long sweep resumable and lets the smaller
budgets finish first). This module reads the runs' ``results.json`` back, and writes a
Markdown table and one figure: mAP (one line per query kind) and ingest seconds per model
against points.

Usage::

    python -m core.evaluation.budget OUT [OUT ...] [--figure budget.png] [--table budget.md]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

__all__ = ["budget_rows", "budget_table", "plot_budget"]

_PREFIX = "points-"


def budget_rows(records: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """One row per (budget, query kind): models, mAP, NN, top-5, n, calls, seconds.

    Parameters
    ----------
    records : list of dict
        ``results.json`` records of ``shapesearch eval`` runs with ``points-<N>`` variants.
    """
    rows = []
    for record in records:
        for name, variant in record["variants"].items():
            if not name.startswith(_PREFIX):
                continue
            for kind, scores in variant["scores"].items():
                stats = variant["stats"][kind]
                rows.append({
                    "points": int(name[len(_PREFIX):]),
                    "query": kind,
                    "models": record["dataset"]["models"],
                    "map": scores["map"],
                    "nn": scores["nn"],
                    "top5": scores["top5"],
                    "n_median": stats["n"]["median"],
                    "calls": stats["solver_calls_mean"],
                    "eigensolve_s": stats["eigensolve_seconds_mean"],
                    "ingest_s": stats["ingest_seconds_mean"],
                })
    return sorted(rows, key=lambda row: (
        -row["models"], row["query"] != "clean", row["query"], row["points"]))


def budget_table(rows: list[dict[str, Any]]) -> str:
    """The sweep as a Markdown table."""
    lines = [
        "| points | query | models | NN | mAP | top-5 | n median | solver calls "
        "| eigen-solve s/model | ingest s/model |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for row in rows:
        lines.append(
            f"| {row['points']} | {row['query']} | {row['models']} | {row['nn']:.3f} "
            f"| {row['map']:.3f} | {row['top5']:.3f} | {row['n_median']:.0f} | {row['calls']:.2f} "
            f"| {row['eigensolve_s']:.2f} | {row['ingest_s']:.2f} |"
        )
    return "\n".join(lines)


def plot_budget(rows: list[dict[str, Any]], path: Path) -> None:
    """mAP per query kind (left axis) and ingest seconds (right axis) against points."""
    from core.evaluation.report import _pyplot

    plt = _pyplot()
    figure, quality = plt.subplots(figsize=(7, 4.5))
    seconds = quality.twinx()
    # One line per query kind and model set: scores of different sets are not comparable.
    for kind, models in dict.fromkeys((row["query"], row["models"]) for row in rows):
        chosen = [row for row in rows if (row["query"], row["models"]) == (kind, models)]
        points = [row["points"] for row in chosen]
        name = f"{kind}, {models} models"
        quality.plot(points, [row["map"] for row in chosen], marker="o", label=f"mAP, {name}")
        seconds.plot(points, [row["ingest_s"] for row in chosen], marker="s", linestyle="--",
                     alpha=0.6, label=f"ingest s/model, {name}")
    quality.set_xscale("log")
    quality.set_xlabel("points per model (max_points)")
    quality.set_ylabel("mAP")
    seconds.set_ylabel("ingest wall s per model (shared machine)")
    quality.set_title("Point budget: retrieval quality and cost")
    quality.grid(alpha=0.3)
    handles = quality.get_legend_handles_labels()
    more = seconds.get_legend_handles_labels()
    quality.legend(handles[0] + more[0], handles[1] + more[1], fontsize=7, loc="center right")
    figure.tight_layout()
    figure.savefig(path, dpi=120)
    plt.close(figure)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+", type=Path, help="eval output folders")
    parser.add_argument("--figure", type=Path, help="write the plot here (PNG)")
    parser.add_argument("--table", type=Path, help="also write the Markdown table here")
    args = parser.parse_args(argv)
    records = [json.loads((run / "results.json").read_text()) for run in args.runs
               if (run / "results.json").exists()]
    rows = budget_rows(records)
    if not rows:
        print("no points-<N> variants in these runs", file=sys.stderr)
        return 2
    table = budget_table(rows)
    print(table)
    if args.table:
        args.table.write_text(table + "\n")
    if args.figure:
        plot_budget(rows, args.figure)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
