"""Issue 24: a tenth library that no setting saw, FreeCAD, as a judge; and the first sprockets.

Why: the held-out set's weakest kinds include roller-chain sprockets (mAP 0.30 with ``ss4``),
and no library here made one, so no figure spoke for them. FreeCAD's own modules draw them
(``core.evaluation.sources.freecad_parts``: 56 parts, 7 kinds; sprockets of ANSI and ISO
chains, external and internal involute gears, and steel sections from Arch's table of
standard profiles: I-beams, channels, rectangular and round tubes). Nothing of it entered
any choice; this file, the source's kinds and sizes and the commands below were committed
before any score on it was seen (2026-11-28, twenty-third session).

Written down before any score:

1. **FreeCAD alone**, leave-one-out within the source: the shipped default against the naive
   HKS baseline (``baseline``), ``ss4`` (the default the issue measured), ``spectral`` and
   ``bendable``; NN, mAP and top-5 in the service's order (the hub discount and the
   k-reciprocal re-rank, as the API answers), the plain order beside; mAP per kind.
2. **The held-out set's kinds across six libraries**: ``bosl2_check.py``'s catalogue of the
   kinds the held-out set has (``HELD_OUT_KINDS``, five libraries) with FreeCAD's spur gears
   merged into ``spur_gear`` and its sprockets as a kind of their own (218 parts).
3. **The reading** (``verdict``): the claim "the shipped default is better than the naive
   baseline on standard parts it never saw" holds on FreeCAD if, on both 1 and 2, the
   default's mAP is above the baseline's and its NN not below, in the service's order;
   otherwise the README and docs/results.md say that it does not hold there. The
   sprockets' mAP (default, ``ss4``, baseline) and what their first answers are taken for
   are reported whatever they are. Nothing in the service changes on these figures.

Added after the figures of 1 and 2 had been seen (disclosed): ``catalogue --all-kinds``
links every kind of the six libraries (FreeCAD's ring gears merged with py-gearworks' and
BOSL2's, its round tubes with MCAD's tubes), the six-library form of ``bosl2_check.py``'s
five libraries by kind; a report, scored the same way (``shapesearch eval`` as above).

Commands (``freecadcmd`` from Debian's ``freecad``; ``openscad`` and the ``tune`` extra for
the five other libraries):

    .venv/bin/python -m core.evaluation.sources /work/tuning \\
        --sources madcad gearworks vslot mcad bosl2 freecad
    .venv/bin/shapesearch eval /work/tuning/freecad \\
        --variants default baseline ss4 spectral bendable --out /work/eval_freecad
    .venv/bin/python bench/selection/freecad_check.py catalogue /work/tuning /work/heldout6
    .venv/bin/shapesearch eval /work/heldout6 \\
        --variants default baseline ss4 spectral bendable --out /work/eval_heldout6
    .venv/bin/python bench/selection/freecad_check.py verdict \\
        /work/eval_freecad /work/eval_heldout6

**Result** (2026-11-28, twenty-third session; docs/results.md, "A tenth library, FreeCAD"):
the claim holds on both. FreeCAD alone, NN / mAP in the service's order: the default 0.929 /
0.895, the baseline 0.821 / 0.843, ``ss4`` 0.768 / 0.769. The held-out set's kinds across six
libraries (218 parts): 0.972 / 0.739 against 0.963 / 0.634. Sprockets: mAP 0.980 alone and
0.860 among the six (``ss4`` 1.000 and 0.889), every first answer a sprocket. Every kind
of the six libraries (``--all-kinds``, 502 parts): 0.888 / 0.687 against the baseline's
0.841 / 0.558, the sprockets 0.415 there (``ss4`` 0.706, ``ss5`` 0.470: lost with the local
words), bevel and spur gears among them.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bosl2_check import HELD_OUT_KINDS as FIVE_LIBRARY_HELD_OUT_KINDS  # noqa: E402
from bosl2_check import LIBRARIES as FIVE_LIBRARIES  # noqa: E402
from bosl2_check import SHARED_KINDS as FIVE_LIBRARY_KINDS  # noqa: E402
from bosl2_check import write_catalogue  # noqa: E402

LIBRARIES: tuple[str, ...] = (*FIVE_LIBRARIES, "freecad")
#: Library kind -> kind: the five libraries' merges, and FreeCAD's spur gears among theirs.
KIND_OF: dict[str, str] = {
    **{member: kind for kind, members in FIVE_LIBRARY_KINDS.items() for member in members},
    "freecad/spur_gear": "spur_gear", "freecad/ring_gear": "ring_gear",
    "mcad/tube": "round_tube", "freecad/round_tube": "round_tube",
}
HELD_OUT_KINDS: tuple[str, ...] = (*FIVE_LIBRARY_HELD_OUT_KINDS, "freecad__sprocket")
#: The variants every reading compares, the shipped default first.
VARIANTS: tuple[str, ...] = ("default", "baseline", "ss4", "spectral", "bendable")
SPROCKET_LABELS: tuple[str, ...] = ("sprocket", "freecad__sprocket")


def scores(run: Path) -> dict[str, dict[str, Any]]:
    """Variant -> its clean scores in the service's order (``service``) and plain order
    (``plain``), and its per-kind table in the service's order (``per_kind``), read from one
    ``shapesearch eval`` run's ``results.json``."""
    record = json.loads((run / "results.json").read_text())
    table: dict[str, dict[str, Any]] = {}
    for name in VARIANTS:
        entry = record["variants"][name]
        table[name] = {"service": entry["hub"]["clean"], "plain": entry["scores"]["clean"],
                       "per_kind": entry["hub_per_class"], "mistakes": entry["per_class"]}
    return table


def claim_holds(table: dict[str, dict[str, Any]]) -> bool:
    """The reading's test: the default's mAP above the baseline's, its NN not below, in the
    service's order."""
    default, baseline = table["default"]["service"], table["baseline"]["service"]
    return default["map"] > baseline["map"] and default["nn"] >= baseline["nn"]


def print_rows(name: str, table: dict[str, dict[str, Any]]) -> None:
    """One run's NN / mAP / top-5 per variant, the service's order and the plain one."""
    print(f"{name}: service's order NN / mAP / top-5 (plain order NN / mAP)")
    for variant, row in table.items():
        service, plain = row["service"], row["plain"]
        print(f"  {variant:9s} {service['nn']:.3f} / {service['map']:.3f} / "
              f"{service['top5']:.3f}   ({plain['nn']:.3f} / {plain['map']:.3f})")


def report(name: str, table: dict[str, dict[str, Any]]) -> bool:
    """Print one run's rows and sprocket rows; returns whether the claim holds on it."""
    print_rows(f"\n{name}", table)
    for label in SPROCKET_LABELS:
        if label in table["default"]["per_kind"]:
            maps = ", ".join(f"{v} {table[v]['per_kind'][label]['map']:.3f}"
                             for v in ("default", "ss4", "baseline"))
            taken = table["default"]["mistakes"][label]["mistakes"] or "-"
            print(f"  sprockets' mAP: {maps}; the default's wrong first answers "
                  f"(plain order): {taken}")
    holds = claim_holds(table)
    print(f"  the default above the baseline (mAP above, NN not below): "
          f"{'holds' if holds else 'does not hold'}")
    return holds


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    commands = parser.add_subparsers(dest="command", required=True)
    build = commands.add_parser("catalogue", help="link the six libraries' held-out kinds")
    build.add_argument("sources", type=Path, help="the folder core.evaluation.sources wrote")
    build.add_argument("out", type=Path, help="the catalogue's folder (links)")
    build.add_argument("--all-kinds", action="store_true",
                       help="every kind of the six libraries, not only the held-out set's")
    read = commands.add_parser("verdict", help="the pre-registered reading of both runs")
    read.add_argument("freecad_run", type=Path, help="eval --out of FreeCAD alone")
    read.add_argument("catalogue_run", type=Path, help="eval --out of the catalogue")
    args = parser.parse_args(argv)
    if args.command == "catalogue":
        write_catalogue(parser, args.sources, args.out,
                        None if args.all_kinds else HELD_OUT_KINDS, LIBRARIES, KIND_OF)
        return 0
    alone = report("FreeCAD alone", scores(args.freecad_run))
    together = report("the held-out kinds of six libraries", scores(args.catalogue_run))
    print(f"\nverdict: the claim {'holds' if alone and together else 'does not hold'} "
          "on FreeCAD")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
