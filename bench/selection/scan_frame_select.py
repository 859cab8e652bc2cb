"""Issue 24, item 5: scan mode's virtual views fixed in each part's own frame?

Why: scan mode describes every catalogue part as 3 virtual partial views from fixed
directions of the *upload* frame (``core.views.view_directions``), so two screws of one kind,
uploaded turned differently, are seen from unrelated sides: one has a view near the scan's
side, the other not, and the kind is found in pieces. Single-view scans still miss the
issue's aim (mAP >= 0.6) on MCAD (0.546), py-gearworks (0.541) and our generator (0.523).
Views fixed in each part's own frame (its principal axes, each signed by the third moment so
that a screw's axis runs from head to tip for every screw) see every part of a kind from
the same sides. Against it: the upload frame's random sides give a kind's parts varied
views, and one of them may lie nearer the scan than any view in a shared frame; which wins
is measured, not assumed. Nothing is fitted; a view costs the same in either frame.

Candidates, written before any score of them was seen (3):

- ``box`` (the reference, as shipped): the 3 Fibonacci directions of the upload frame;
- ``frame t<deg>``: the three signed principal axes turned by ``deg`` degrees about their
  diagonal (``core.views.frame_directions``): an end view, a side view and a top view, each
  leaning off its axis so that a flat part is never seen edge-on (the Fibonacci directions
  in the part's frame would see every plate edge-on in one view, so they are not a
  candidate). ``deg`` in {20, 45}.

Every candidate's catalogue is each model whole and its 3 views of that candidate; scored in
the search service's scan-mode order of the time (the hub discount among entries, the first
answer's expansion: ``scan_expansion_select.round_one_positions``), leave-one-out as
everywhere (a query is a scan of one model, whose entries leave the catalogue for it).

The rule and the four ship tests are ``scan_hubs_select.rule_and_tests`` (as the scan hub,
revolve and expansion studies): single-view scan mAP per source, the mean over the seven
tuning sources, ties within 0.002 to ``box`` first, then the smaller tilt; leave-one-
source-out with a 95 % paired bootstrap over queries against ``box``. It ships only if all
hold: (1) left out above ``box`` by more than 0.002, interval above zero; (2) merged
three-view scans and clean queries (scan mode), mean of seven, each not below ``box``'s by
more than 0.002; (3) BOSL2 (chose nothing) not below by more than 0.002; (4) the
``bendable`` family's single-view mean over (bendable, capod-nonrigid) not below by more
than 0.002.

Cost, stated before the run: ingest the same (3 views; a 3 x 3 eigenproblem per part);
query the same. A catalogue that adopts it re-describes its views.

Data (``scan_retrieval --extra-kinds``: the frame views are described and saved beside the
shipped ones; every scan and every whole model as in the sixteenth session's studies):

    .venv/bin/python -m core.evaluation.scan_retrieval /work/tuning/<source> \\
        --out /work/scanframe/<source> --per-class P --views 3 \\
        --kinds clean multi+sor single+sor --descriptors default bendable \\
        --extra-kinds fview0t20 fview1t20 fview2t20 fview0t45 fview1t45 fview2t45
        # P 0; generated 5; capod 6; bosl2 from /work/tuning-bosl2
    .venv/bin/python bench/selection/scan_frame_select.py /work/scanframe \\
        --json /work/scanframe/frame.json

**Result** (2026-11-28, seventeenth session; docs/results.md, "Scan mode's views fixed in
each part's own frame"): declined. The rule keeps ``box`` on the seven and without each
(left out +0.0000); mean of seven 0.6834 against 0.6673 (t20) and 0.6674 (t45): first
answers fall on four or five sources of seven (pymadcad NN 0.917 -> 0.842 / 0.875, capod
0.817 -> 0.750 / 0.683); MCAD alone gains (0.531 -> 0.548 at 45 degrees).
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
from scan_expansion_select import round_one_positions, whole_rows  # noqa: E402
from scan_hubs_select import (  # noqa: E402
    VIEWS,
    ranked_scores,
    run_study,
    source_catalogue,
    study_arguments,
    tabulate,
)

REFERENCE = "box"
TILTS = (20, 45)


def candidates() -> dict[str, tuple[str, ...]]:
    """Candidate name -> its view entry kinds, in the rule's tie order."""
    grid = {REFERENCE: VIEWS}
    for degrees in TILTS:
        grid[f"frame t{degrees}"] = tuple(f"fview{index}t{degrees}" for index in range(3))
    return grid


def score_all(root: Path, descriptor: str, sources: tuple[str, ...], kind: str
              ) -> tuple[Table, dict[str, dict[str, np.ndarray]]]:
    """Every candidate on every source for the ``kind`` queries, in scan mode's order."""
    def scored(source: str, views: tuple[str, ...]) -> tuple[dict[str, float], np.ndarray]:
        catalogue = source_catalogue(root, source, descriptor, kinds=(kind,), views=views)
        return ranked_scores(catalogue, kind, round_one_positions(
            catalogue.queries[kind], catalogue.entries, catalogue.owners,
            catalogue.query_models[kind], whole_rows(catalogue)))

    return tabulate(sources, lambda source: {
        name: scored(source, views) for name, views in candidates().items()})


def main(argv: list[str] | None = None) -> int:
    args = study_arguments(__doc__, argv)
    record = run_study(args.out, score_all, list(candidates()), REFERENCE)
    if args.json:
        args.json.write_text(json.dumps(record, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
