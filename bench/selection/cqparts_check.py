"""Issue 24: an eleventh library that no setting saw, cqparts, as a judge; screw heads again.

Why: the held-out set's weakest kinds are screws that differ by their head (button-head
0.31, socket-head cap 0.36, hex-head 0.41, countersunk 0.46 mAP with ``ss4``), and the one
projection of the held-out mAP we have comes from a single library, BOSL2, which reproduces
the issue's NN references but not its mAP ones (by distance alone ``ss4`` mAP 0.689 there,
0.580 held out), so the projection (0.66-0.68) rests on carrying a difference or a ratio
across. cqparts (``core.evaluation.sources.cqparts_parts``: 80 parts, 10 kinds) is another
maker: hex bolts, hex and square nuts and wood screws from the Bolt Depot catalogue it
ships; socket-head, button-head, countersunk and pan-head screws in the same eight sizes;
ball and tapered roller bearings. Nothing of it entered any choice; this file, the source's
kinds and sizes and the commands below were committed before any score on it was seen
(2026-12-06, forty-second session).

Written down before any score:

1. **cqparts alone**, leave-one-out within the source: the shipped default against the
   naive HKS baseline (``baseline``), ``ss4`` (the default the issue measured), ``spectral``
   and ``bendable``; NN, mAP and top-5 in the service's order (the hub discount and the
   k-reciprocal re-rank, as the API answers), the plain order beside; mAP per kind.
2. **The claim** "the shipped default is better than the naive baseline on standard parts
   it never saw" holds on cqparts if the default's mAP is above the baseline's and its NN
   not below, in the service's order; otherwise the README and docs/results.md say that it
   does not hold there.
3. **Is cqparts a likeness of the held-out set?** It reproduces the issue's references if,
   by distance alone (the order the issue measured in), ``ss4``'s and the baseline's NN are
   each within 0.03 of the held-out's (0.882, 0.914) and their mAP each within 0.05 of it
   (0.580, 0.578). If all four hold, the held-out projection becomes cqparts' own: the
   release's NN and mAP in the service's order. If only the NN pair holds (as on BOSL2), the
   release is carried over as BOSL2's was (its difference over ``ss4`` by distance alone,
   and its ratio for mAP), and reported beside BOSL2's projection. Otherwise the projection
   stays BOSL2's and cqparts is reported as one more library.
4. **Screw heads** (a report): ``screw_heads_report.py`` on the four machine-screw kinds,
   which share their sizes: how often a same-size screw of another head ranks above the
   median screw of the query's own head, for the whole descriptor and for each block.

5. **Scans** (issue 24, item 5; added before any score, in its own commit): cqparts' parts
   as single-view and three-view scans queried in scan mode against the clean parts, as
   the other sources' scans were measured (``core.evaluation.scan_retrieval``, 3 views, the
   service's scan order), reported against the aim of single-view mAP >= 0.6.

Nothing in the service changes on these figures.

Added after the figures of 1 to 4 had been seen (disclosed): ``catalogue`` links the
held-out set's kinds across seven libraries, ``freecad_check.py``'s six and cqparts, with
cqparts' socket-head, button-head and countersunk screws, hex bolts (as hex-head screws),
hex nuts and ball bearings merged into those kinds (``KIND_OF``: what each part is, from the
source builder) and its tapered roller bearings a kind of their own; scored by
``shapesearch eval`` as ``freecad_check.py``'s six-library catalogue was, the nearest
likeness of the held-out scoring (several makers' styles per kind).

(The reading's command took the run alone when committed; it became ``verdict RUN`` when
the catalogue was added, the reading unchanged.)

Commands (``freecadcmd`` from Debian's ``freecad``; cqparts and CadQuery 1.x in
``/opt/cqparts``, as ``core.evaluation.sources.cqparts_parts`` says):

    .venv/bin/python -m core.evaluation.sources /work/tuning --sources cqparts
    .venv/bin/shapesearch eval /work/tuning/cqparts \\
        --variants default baseline ss4 spectral bendable --out /work/eval_cqparts
    .venv/bin/python bench/selection/cqparts_check.py verdict /work/eval_cqparts
    .venv/bin/python bench/selection/screw_heads_report.py /work/tuning/cqparts \\
        --heads socket_head_screw button_head_screw countersunk_screw pan_head_screw
    .venv/bin/python -m core.evaluation.scan_retrieval /work/tuning/cqparts \\
        --out /work/scan_cqparts --per-class 0 --views 3 --kinds clean multi+sor single+sor
    # disclosed, after 1 to 4: the held-out set's kinds across seven libraries
    .venv/bin/python -m core.evaluation.sources /work/tuning \\
        --sources madcad gearworks vslot mcad bosl2 freecad
    .venv/bin/python bench/selection/cqparts_check.py catalogue /work/tuning /work/heldout7
    .venv/bin/shapesearch eval /work/heldout7 \\
        --variants default baseline ss4 spectral bendable --out /work/eval_heldout7
    .venv/bin/python bench/selection/cqparts_check.py verdict /work/eval_cqparts \\
        --held-out-run /work/eval_heldout7
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bosl2_check import write_catalogue  # noqa: E402
from freecad_check import HELD_OUT_KINDS as SIX_LIBRARY_HELD_OUT_KINDS  # noqa: E402
from freecad_check import KIND_OF as SIX_LIBRARY_KIND_OF  # noqa: E402
from freecad_check import LIBRARIES as SIX_LIBRARIES  # noqa: E402
from freecad_check import claim_holds, print_rows, scores  # noqa: E402

LIBRARIES: tuple[str, ...] = (*SIX_LIBRARIES, "cqparts")
#: Library kind -> kind: the six libraries' merges, and cqparts' parts of those kinds.
KIND_OF: dict[str, str] = {
    **SIX_LIBRARY_KIND_OF,
    "cqparts/socket_head_screw": "socket_head_screw",
    "cqparts/button_head_screw": "button_head_screw",
    "cqparts/countersunk_screw": "countersunk_screw",
    "cqparts/hex_bolt": "hex_head_screw",
    "cqparts/hex_nut": "hex_nut",
    "cqparts/ball_bearing": "ball_bearing",
}
HELD_OUT_KINDS: tuple[str, ...] = (*SIX_LIBRARY_HELD_OUT_KINDS,
                                   "cqparts__tapered_roller_bearing")

#: The issue's references on its held-out parts, by distance alone: (NN, mAP).
HELD_OUT: dict[str, tuple[float, float]] = {"ss4": (0.882, 0.580), "baseline": (0.914, 0.578)}
#: How near a reference must come to count as reproduced: (NN, mAP).
TOLERANCE = (0.03, 0.05)
#: BOSL2's projection of the held-out mAP (docs/results.md, "The release judged on parts
#: no choice saw").
BOSL2_PROJECTION = "NN about 0.95, mAP 0.66-0.68"


def likeness(table: dict[str, dict[str, Any]]) -> tuple[bool, bool]:
    """Whether the references' NN pair, and their mAP pair, come out as held out (test 3)."""
    near = [[abs(table[name]["plain"][metric] - reference[at]) <= TOLERANCE[at]
             for at, metric in enumerate(("nn", "map"))]
            for name, reference in HELD_OUT.items()]
    return all(row[0] for row in near), all(row[1] for row in near)


def carried_over(table: dict[str, dict[str, Any]]) -> tuple[float, float, float]:
    """The release carried onto the held-out parts as BOSL2's was: NN by its difference over
    ``ss4`` by distance alone, mAP by that difference and by that ratio."""
    release, ss4 = table["default"]["service"], table["ss4"]["plain"]
    return (HELD_OUT["ss4"][0] + release["nn"] - ss4["nn"],
            HELD_OUT["ss4"][1] + release["map"] - ss4["map"],
            HELD_OUT["ss4"][1] * release["map"] / ss4["map"])


def print_per_kind(table: dict[str, dict[str, Any]], mistakes: bool) -> None:
    """mAP per kind in the service's order (default / baseline / ``ss4``), and with
    ``mistakes`` the default's wrong first answers in plain order."""
    print("mAP per kind, service's order (default / baseline / ss4)"
          + ("; the default's wrong first answers, plain order:" if mistakes else ":"))
    for kind in sorted(table["default"]["per_kind"]):
        maps = " / ".join(f"{table[v]['per_kind'][kind]['map']:.3f}"
                          for v in ("default", "baseline", "ss4"))
        taken = f"   {table['default']['mistakes'][kind]['mistakes'] or '-'}" if mistakes else ""
        print(f"  {kind:36s} {maps}{taken}")


def verdict(run: Path, held_out_run: Path | None) -> None:
    """Tests 2 and 3 on cqparts alone (``run``), and the seven-library catalogue's rows."""
    table = scores(run)
    print_rows("cqparts alone", table)
    print_per_kind(table, mistakes=True)
    holds = claim_holds(table)
    print(f"test 2, the default above the baseline (mAP above, NN not below): "
          f"{'holds' if holds else 'does not hold'}")
    nn_alike, map_alike = likeness(table)
    print(f"test 3, the references as held out: NN {'yes' if nn_alike else 'no'}, "
          f"mAP {'yes' if map_alike else 'no'}")
    release = table["default"]["service"]
    if nn_alike and map_alike:
        print(f"  the held-out projection is cqparts' own: NN {release['nn']:.3f}, "
              f"mAP {release['map']:.3f}")
    elif nn_alike:
        nn, by_difference, by_ratio = carried_over(table)
        print(f"  carried over as BOSL2's: NN {nn:.3f}, mAP {by_difference:.3f} (difference) "
              f"to {by_ratio:.3f} (ratio); BOSL2's: {BOSL2_PROJECTION}")
    else:
        print(f"  the projection stays BOSL2's: {BOSL2_PROJECTION}")
    if held_out_run is not None:
        seven = scores(held_out_run)
        print_rows("\nthe held-out set's kinds across seven libraries", seven)
        print_per_kind(seven, mistakes=False)
        print(f"the default above the baseline there: "
              f"{'holds' if claim_holds(seven) else 'does not hold'}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    commands = parser.add_subparsers(dest="command", required=True)
    read = commands.add_parser("verdict", help="the pre-registered reading")
    read.add_argument("run", type=Path, help="shapesearch eval --out of cqparts alone")
    read.add_argument("--held-out-run", type=Path,
                      help="shapesearch eval --out of the seven-library catalogue, reported too")
    build = commands.add_parser("catalogue", help="link the held-out set's kinds of seven "
                                "libraries (disclosed, after tests 1 to 4)")
    build.add_argument("sources", type=Path, help="the folder core.evaluation.sources wrote")
    build.add_argument("out", type=Path, help="the catalogue's folder (links)")
    args = parser.parse_args(argv)
    if args.command == "verdict":
        verdict(args.run, args.held_out_run)
        return 0
    write_catalogue(parser, args.sources, args.out, HELD_OUT_KINDS, LIBRARIES, KIND_OF)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
