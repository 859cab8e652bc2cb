"""Evaluation output: a Markdown report, a JSON record and PNG plots (matplotlib, Agg).

Everything here formats numbers that ``core.evaluation.cli`` has already computed; nothing
is measured here.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

__all__ = [
    "markdown_report",
    "plots_from_record",
    "plot_cutoff_vs_points",
    "plot_eigensolve_seconds",
    "plot_precision_recall",
    "write_json",
]

_METRIC_HEADERS = ("NN", "FT", "ST", "DCG", "mAP", "top-5")
_METRIC_KEYS = ("nn", "ft", "st", "dcg", "map", "top5")


def write_json(record: dict[str, Any], path: Path) -> None:
    """Write ``record`` as indented JSON (numpy scalars and arrays converted)."""

    def convert(value: Any) -> Any:
        if isinstance(value, np.ndarray):
            return value.tolist()
        if isinstance(value, np.generic):
            return value.item()
        raise TypeError(f"cannot serialise {type(value)}")

    path.write_text(json.dumps(record, indent=1, default=convert, sort_keys=False))


def _fmt(value: float | None, digits: int = 3) -> str:
    return "-" if value is None or not np.isfinite(value) else f"{value:.{digits}f}"


def variant_table(variants: dict[str, dict[str, Any]], key: str = "clean") -> str:
    """Markdown table of one scoring (``clean``, ``single``, ``multi``) for every variant."""
    header = (
        "| variant | n median [min-max] | solver calls (mean) | eigensolve s/model "
        "| ingest s/model | " + " | ".join(_METRIC_HEADERS) + " |"
    )
    lines = [header, "|" + "---|" * (5 + len(_METRIC_HEADERS))]
    for name, record in variants.items():
        scores = record.get("scores", {}).get(key)
        if not scores:
            continue
        stats = record.get("stats", {}).get(key, {})
        n = stats.get("n", {})
        lines.append(
            f"| {name} | {n.get('median', 0):.0f} [{n.get('min', 0):.0f}-{n.get('max', 0):.0f}]"
            f" | {_fmt(stats.get('solver_calls_mean'), 2)}"
            f" | {_fmt(stats.get('eigensolve_seconds_mean'), 2)}"
            f" | {_fmt(stats.get('ingest_seconds_mean'), 2)} | "
            + " | ".join(_fmt(scores[k]) for k in _METRIC_KEYS)
            + " |"
        )
    return "\n".join(lines)


def hub_table(record: dict[str, Any]) -> str:
    """Every scoring with the hub discount (``core.rank.hubness``) beside the plain one."""
    hub = record["hub_discount"]
    again = hub.get("reciprocal")
    lines = [
        f"## With a hub discount (CSLS, k {hub['neighbours']}, weight {hub['weight']:g})"
        + (f", re-ranked k-reciprocally (k1 {again['neighbours']}, k2 {again['expansion']}, "
           f"lambda {again['blend']:g}; the discount's first answer kept first) for clean "
           "queries" if again else ""),
        "",
        "The search service orders shape-mode answers this way (its default, k 10); the "
        "tables above rank by plain distance, the descriptor's own order. Scans are "
        "ranked by the hub discount alone.",
        "",
        *_beside_plain(record, "hub", "plain"),
    ]
    return "\n".join(lines)


def scan_mode_table(record: dict[str, Any]) -> str:
    """The scans scored in the service's scan mode beside shape mode (the scan table)."""
    mode = record["scan_mode"]
    order = ("the hub discount among entries, then the first answer's kind"
             if mode["discounted"] else "best entry")
    lines = [
        f"## Scans in scan mode ({mode['views']} virtual views per model)",
        "",
        "Every model is an entry whole and as each of its virtual views, one result per "
        f"model, ranked as the service's `mode=scan` answers 10 results ({order}). The "
        "shape-mode columns are the scan table's, plain order.",
        "",
        *_beside_plain(record, "scan_mode", "shape mode"),
    ]
    return "\n".join(lines)


def _beside_plain(record: dict[str, Any], key: str, plain_name: str) -> list[str]:
    """Table header and rows: each variant's ``key`` scores per query kind beside its plain
    ``scores`` of the same kind (NN, mAP, top-5 each)."""
    lines = [
        "| variant | queries | NN | mAP | top-5 | "
        + " | ".join(f"{plain_name} {m}" for m in ("NN", "mAP", "top-5")) + " |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for name, entry in record["variants"].items():
        for kind, scores in entry.get(key, {}).items():
            plain = entry["scores"][kind]
            lines.append(
                f"| {name} | {kind} | "
                + " | ".join(_fmt(v[m]) for v in (scores, plain) for m in ("nn", "map", "top5"))
                + " |"
            )
    return lines


def per_class_table(record: dict[str, Any]) -> str:
    """The first answers per kind of one variant (``default`` when scored, else the first),
    clean queries, worst mAP first: the kinds that fail and what they are taken for."""
    scored = {name: v for name, v in record["variants"].items() if "per_class" in v}
    name = "default" if "default" in scored else next(iter(scored))
    per_class = scored[name]["per_class"]
    # With --hub-discount, each kind's NN and mAP with it too.
    hub = scored[name].get("hub_per_class", {})
    extra = " NN / mAP in the service's order |" if hub else ""
    lines = [
        f"## Per kind (variant {name}, clean queries), worst mAP first",
        "",
        "| kind | queries | NN | mAP | wrong first answers |" + extra,
        "|---|---|---|---|---|" + ("---|" if hub else ""),
    ]
    for label, row in sorted(per_class.items(), key=lambda item: (item[1]["map"], item[0])):
        mistakes = ", ".join(f"{other} ({count})" for other, count in row["mistakes"].items())
        with_hub = (f" {_fmt(hub[label]['nn'])} / {_fmt(hub[label]['map'])} |"
                    if label in hub else (" - |" if hub else ""))
        lines.append(f"| {label} | {row['queries']} | {_fmt(row['nn'])} | {_fmt(row['map'])} |"
                     f" {mistakes or '-'} |" + with_hub)
    return "\n".join(lines)


def scan_table(variants: dict[str, dict[str, Any]]) -> str:
    """Clean against scanned queries, per variant: mAP, top-5 and NN side by side."""
    lines = [
        "| variant | query | NN | FT | DCG | mAP | top-5 | drop in mAP | drop in top-5 |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for name, record in variants.items():
        scores = record.get("scores", {})
        if len(scores) < 2:
            continue
        clean = scores["clean"]
        for key in scores:
            if key not in scores:
                continue
            s = scores[key]
            drop_map = "" if key == "clean" else _fmt(clean["map"] - s["map"])
            drop_top = "" if key == "clean" else _fmt(clean["top5"] - s["top5"])
            lines.append(
                f"| {name} | {key} | {_fmt(s['nn'])} | {_fmt(s['ft'])} | {_fmt(s['dcg'])} "
                f"| {_fmt(s['map'])} | {_fmt(s['top5'])} | {drop_map} | {drop_top} |"
            )
    return "\n".join(lines)


def resampling_table(resampling: dict[str, Any]) -> str:
    """Summary of the resampling consistency study."""
    if not resampling:
        return "(not run)"
    lines = [
        "| variant | models | point counts | n spread median (max-min)/median | worst spread "
        "| NN is same model | NN same class |",
        "|---|---|---|---|---|---|---|",
    ]
    for name, record in resampling.get("variants", {}).items():
        lines.append(
            f"| {name} | {resampling['models']} | {', '.join(map(str, resampling['sizes']))} "
            f"| {_fmt(record['spread_median'])} | {_fmt(record['spread_max'])} "
            f"| {_fmt(record['nn_same_model'])} | {_fmt(record['nn_same_class'])} |"
        )
    return "\n".join(lines)


def markdown_report(record: dict[str, Any]) -> str:
    """The whole report as Markdown."""
    dataset = record["dataset"]
    parts = [
        "# shapesearch eval",
        "",
        f"- command: `{record['command']}`",
        f"- dataset: {dataset['root']} ({dataset['models']} models, {dataset['classes']} classes;"
        f" duplicates dropped: {dataset['duplicates'] or 'none'};"
        f" .cla mismatches: {dataset['cla_mismatches'] or 'none'})",
        f"- machine: {record['machine']}",
        f"- wall time: {record['wall_seconds']:.0f} s"
        f" (eigenpairs computed this run: {record['computed_samplings']},"
        f" from cache: {record['cached_samplings']})",
        f"- failures: {record['failures'] or 'none'}",
        "",
        "## Clean models (each randomly rotated), leave-one-out",
        "",
        variant_table(record["variants"], "clean"),
        "",
        "Eigen-solve seconds per model are estimated from the solver's per-band timings"
        " (what the variant's own solver would have spent); ingest = load + Laplacian +"
        " eigen-solve + signature and histogram.",
    ]
    direct = record.get("direct_timing")
    if direct:
        parts += [
            "",
            f"Direct check on {direct['models']} models (fresh solver per variant), mean seconds:",
            "",
            "| variant | estimated | measured |",
            "|---|---|---|",
        ]
        for name, row in direct["variants"].items():
            parts.append(f"| {name} | {_fmt(row['estimated'], 2)} | {_fmt(row['measured'], 2)} |")
    if any(len(v.get("scores", {})) > 1 for v in record["variants"].values()):
        parts += [
            "",
            "## Simulated scans queried against the clean models",
            "",
            "Each scan's own clean model is left out of the database.",
            "",
            scan_table(record["variants"]),
        ]
    if any("per_class" in v for v in record["variants"].values()):
        parts += ["", per_class_table(record)]
    if record.get("hub_discount"):
        parts += ["", hub_table(record)]
    if record.get("scan_mode"):
        parts += ["", scan_mode_table(record)]
    if record.get("resampling"):
        parts += ["", "## Resampling consistency", "", resampling_table(record["resampling"])]
    parts += ["", "## Plots", ""]
    for name in record.get("plots", []):
        parts.append(f"![{name}]({name})")
    return "\n".join(parts) + "\n"


def _pyplot() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _styles(count: int) -> list[dict[str, Any]]:
    """Distinct colour and line style per series (matplotlib's default cycle has only 10)."""
    plt = _pyplot()
    colours = plt.get_cmap("tab20").colors
    dashes = ("-", "--", "-.", ":")
    return [
        {"color": colours[i % len(colours)], "linestyle": dashes[(i // 10) % len(dashes)]}
        for i in range(count)
    ]


def plot_cutoff_vs_points(
    series: dict[str, tuple[np.ndarray, np.ndarray]], path: Path, fixed: int = 300
) -> None:
    """The paper's Figure 7: cutoff ``n`` against point count, one marker per model sampling.

    Parameters
    ----------
    series : dict name -> (points (m,), n (m,))
    fixed : int
        Drawn as a horizontal line (the fixed-count baseline).
    """
    plt = _pyplot()
    figure, axes = plt.subplots(figsize=(7, 4.5))
    for name, (points, counts) in series.items():
        jitter = np.random.default_rng(0).uniform(0.97, 1.03, len(points))
        axes.scatter(np.asarray(points) * jitter, counts, s=9, alpha=0.6, label=name)
    axes.axhline(fixed, color="black", linestyle="--", linewidth=1, label=f"fixed {fixed}")
    axes.set_xscale("log")
    axes.set_xlabel("points per model (jittered)")
    axes.set_ylabel("eigenpairs n chosen by the cutoff")
    axes.set_title("Adaptive cutoff n against point count")
    axes.legend(fontsize=7)
    figure.tight_layout()
    figure.savefig(path, dpi=120)
    plt.close(figure)


def plot_precision_recall(
    curves: dict[str, tuple[np.ndarray, np.ndarray]], path: Path, title: str
) -> None:
    """Mean interpolated precision against recall, one line per variant."""
    plt = _pyplot()
    figure, axes = plt.subplots(figsize=(7, 5))
    styles = _styles(len(curves))
    for style, (name, (recall, precision)) in zip(styles, curves.items(), strict=True):
        axes.plot(recall, precision, marker=".", linewidth=1, label=name, **style)
    axes.set_xlabel("recall")
    axes.set_ylabel("precision")
    axes.set_ylim(0, 1.02)
    axes.set_title(title)
    axes.grid(alpha=0.3)
    axes.legend(fontsize=7, loc="lower left")
    figure.tight_layout()
    figure.savefig(path, dpi=120)
    plt.close(figure)


def plot_eigensolve_seconds(seconds: dict[str, np.ndarray], path: Path) -> None:
    """Eigen-solve seconds per model, one box per variant."""
    plt = _pyplot()
    names = list(seconds)
    figure, axes = plt.subplots(figsize=(max(6, 0.6 * len(names) + 2), 4.5))
    axes.boxplot([seconds[name] for name in names], showfliers=True)
    axes.set_xticks(range(1, len(names) + 1), names, rotation=40, ha="right", fontsize=7)
    axes.set_ylabel("eigen-solve seconds per model")
    axes.set_title("Eigen-solve time per variant (estimated from band timings)")
    axes.grid(axis="y", alpha=0.3)
    figure.tight_layout()
    figure.savefig(path, dpi=120)
    plt.close(figure)


def plots_from_record(record: dict[str, Any], out: Path) -> list[str]:
    """Write every plot from the JSON record of a run; returns the file names.

    Works on a record read back from ``results.json``, so plots can be redrawn without
    recomputing anything.
    """
    names: list[str] = []
    variants = record["variants"]
    figure7: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    for name, study in record.get("resampling", {}).get("variants", {}).items():
        rows = study["per_model"]
        for column, size in enumerate(record["resampling"]["sizes"]):
            figure7[f"{name} @ {size} pts ({len(rows)} models)"] = (
                np.array([row["points"][column] for row in rows]),
                np.array([row["n"][column] for row in rows]),
            )
    for name in ("default",):
        if name in variants and variants[name]["settings"]["cutoff"]["mode"] == "adaptive":
            per_model = variants[name]["per_model"]
            figure7[f"{name} (all {len(per_model)} models)"] = (
                np.array([row["points"] for row in per_model.values()]),
                np.array([row["n"] for row in per_model.values()]),
            )
    if figure7:
        plot_cutoff_vs_points(figure7, out / "cutoff_vs_points.png")
        names.append("cutoff_vs_points.png")
    kinds = {kind for record_ in variants.values() for kind in record_.get("pr", {})}
    for kind in sorted(kinds, key=lambda k: (k != "clean", k)):
        curves = {
            name: (np.asarray(v["pr"][kind]["recall"]), np.asarray(v["pr"][kind]["precision"]))
            for name, v in variants.items()
            if kind in v.get("pr", {})
        }
        file = f"precision_recall_{kind.replace('+', '_')}.png"
        plot_precision_recall(curves, out / file, f"Precision-recall ({kind} queries)")
        names.append(file)
    seconds = {
        name: np.array([row["eig_s"] for row in v["per_model"].values()])
        for name, v in variants.items()
        if v.get("per_model")
    }
    if seconds:
        plot_eigensolve_seconds(seconds, out / "eigensolve_seconds.png")
        names.append("eigensolve_seconds.png")
    return names


def main(argv: list[str] | None = None) -> int:
    """``python -m core.evaluation.report OUT``: redraw plots and Markdown from results.json."""
    import sys

    out = Path((argv or sys.argv[1:])[0])
    record = json.loads((out / "results.json").read_text())
    record["plots"] = plots_from_record(record, out)
    (out / "results.md").write_text(markdown_report(record))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
