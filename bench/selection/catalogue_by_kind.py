"""Issue 24: the four third-party libraries as one catalogue, scored by kind as the held-out set is.

Why: the held-out set counts an answer right when it is of the query's kind, whatever
standard or size made it ("several standards and sizes per kind"). The one-catalogue check of
``mcad_check.py`` labels each part by its library and kind, so a hex bolt of OpenSCAD's MCAD
that finds a pymadcad hex-head screw counts as wrong, although a held-out scorer would count
it right. This script scores the same catalogue (pymadcad, py-gearworks, bd-vslot, MCAD: 326
parts) with the kinds that several libraries make merged into one label (``SHARED_KINDS``,
decided by what each library's part is, from its documentation and the source builders in
``core/evaluation/sources``, not from any score).

Disclosed: this script was written after the eleventh session's first-answer mistakes of the
library-labelled catalogue had been looked at (12th session: 54 of 326 first answers wrong in
the service's order; 29 of them py-gearworks' gears taken for other gear kinds, 27 of those
spur, helical and herringbone gears for each other; 10 MCAD's blocks and rounded boxes for
each other; 5 a part of one library taken for the same kind from another). It reports; it
chooses nothing.

Reported for each descriptor family the service can hold, ``ss9`` (the rigid default),
``spectral`` (the intrinsic default before issue 12) and ``bendable`` (``spectral`` with the
idf word counts of HKS on 64 words at weight 2), plain cosine order and the search service's
order (k-reciprocal ``k1`` 5, ``k2`` 3, ``lambda`` 0.3 with the hub discount's keys as its
distance term, ``core.rank.reciprocal``), and (added in the same session, after the results
below) the hub discount alone: NN, mAP and top-5 over the catalogue (leave-one-out), by
kind and by library kind; then the service order's first answers by kind. Every local block
is encoded by one vocabulary fitted on the other four sources (none of the catalogue's).

    nice -n 10 .venv/bin/python bench/selection/catalogue_by_kind.py /work/study8 \\
        --json /work/study8/catalogue_by_kind.json

(``/work/study8`` as ``mcad_check.py`` builds it.)
"""

from __future__ import annotations

import json
import os
import sys
from collections import Counter
from pathlib import Path

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from extraction_select import BENDABLE_WORDS_WEIGHT  # noqa: E402
from hub_measures_select import REFERENCE  # noqa: E402
from hubness_select import pooled_labels, pooled_local, pooled_rows  # noqa: E402
from local_features_select import Study, joined  # noqa: E402
from mcad_check import CANDIDATE, CATALOGUE, KEYS  # noqa: E402
from profile_block_select import study_command  # noqa: E402

from core.evaluation.metrics import ranked_relevance, score_rankings  # noqa: E402

#: Library kinds that are one kind of part: a sealed 6xx bearing of bd-vslot is a deep-groove
#: ball bearing; pymadcad's "flat head" screws are countersunk; MCAD's bolts are the screws
#: of the same heads; both gear libraries make spur, helical and bevel gears.
SHARED_KINDS: dict[str, tuple[str, ...]] = {
    "ball_bearing": ("madcad/ball_bearing", "mcad/ball_bearing", "vslot/bearing"),
    "hex_head_screw": ("madcad/screw_hex_head", "mcad/hex_bolt"),
    "socket_head_screw": ("madcad/screw_socket_head", "mcad/cap_bolt"),
    "countersunk_screw": ("madcad/screw_flat_head", "mcad/countersunk_bolt"),
    "spur_gear": ("gearworks/spur_gear", "mcad/spur_gear"),
    "helical_gear": ("gearworks/helical_gear", "mcad/helical_gear"),
    "bevel_gear": ("gearworks/bevel_gear", "mcad/bevel_gear"),
}
KIND_OF = {member: kind for kind, members in SHARED_KINDS.items() for member in members}
PLAIN_ORDER = "ss9"  # the plain-cosine candidate's name in ``KEYS``
#: Plain cosine, the hub discount alone (the service's order until the eleventh session) and
#: the service's order.
ORDERS = {"plain": PLAIN_ORDER, "discount": REFERENCE, "service": CANDIDATE}


def bendable_rows(study: Study) -> np.ndarray:
    """The ``bendable`` family's unit rows of the catalogue, its words fitted on the other
    sources (the catalogue's order of ``pooled_rows``)."""
    by_name = {s.name: s for s in study.sources}
    words = pooled_local(study, CATALOGUE, "hks", "bof")
    return np.vstack([joined(by_name[name].bases["spectral"], words[name],
                             BENDABLE_WORDS_WEIGHT) for name in CATALOGUE])


def family_rows(study: Study) -> dict[str, np.ndarray]:
    """Each family's unit rows ``(326, d)`` of the catalogue, in ``pooled_rows``' order."""
    by_name = {s.name: s for s in study.sources}
    ss9, _ = pooled_rows(study, CATALOGUE)
    spectral = joined(np.vstack([by_name[name].bases["spectral"] for name in CATALOGUE]),
                      None, 0.0)
    return {"ss9": ss9, "spectral": spectral, "bendable": bendable_rows(study)}


def scores(keys: np.ndarray, labels: list[str]) -> dict[str, float]:
    relevance = ranked_relevance(keys, labels, labels, np.eye(len(labels), dtype=bool))
    return score_rankings(relevance)


def print_orders(name: str, rows: np.ndarray, kinds: list[str]) -> dict[str, dict[str, float]]:
    """Score unit ``rows`` of the one catalogue by ``kinds`` in plain cosine order and in the
    service's; print and return both."""
    results = {}
    for order, keys in ORDERS.items():
        results[order] = scores(KEYS[keys](rows), kinds)
        print(f"one catalogue by kind, {name}, {order}: NN {results[order]['nn']:.3f}, "
              f"mAP {results[order]['map']:.3f}, top-5 {results[order]['top5']:.3f}")
    return results


def first_answers(keys: np.ndarray, kinds: list[str]) -> dict[str, dict[str, object]]:
    """Per kind: its parts, how many first answers are of the kind, and the kinds taken."""
    masked = np.array(keys, dtype=np.float64)
    np.fill_diagonal(masked, np.inf)
    first = masked.argmin(axis=1)
    table: dict[str, dict[str, object]] = {}
    for kind in sorted(set(kinds)):
        rows = [i for i, k in enumerate(kinds) if k == kind]
        taken = Counter(kinds[first[i]] for i in rows if kinds[first[i]] != kind)
        table[kind] = {"parts": len(rows), "right": len(rows) - sum(taken.values()),
                       "taken_for": dict(taken.most_common())}
    return table


def main(argv: list[str] | None = None) -> int:
    args, study, _ = study_command(__doc__, argv)
    library_kinds = pooled_labels(study, CATALOGUE)
    kinds = [KIND_OF.get(label, label) for label in library_kinds]
    print(f"one catalogue: {len(kinds)} parts, {len(set(library_kinds))} library kinds, "
          f"{len(set(kinds))} kinds")
    report: dict[str, object] = {}
    service_keys = None
    print(f"{'family':9s} {'order':8s} {'by kind: NN   mAP    top-5':28s} "
          f"{'by library kind: NN   mAP    top-5'}")
    for family, rows in family_rows(study).items():
        for order, name in ORDERS.items():
            keys = KEYS[name](rows)
            by_kind, by_library = scores(keys, kinds), scores(keys, library_kinds)
            report[f"{family} {order}"] = {"by_kind": by_kind, "by_library_kind": by_library}
            print(f"{family:9s} {order:8s}     {by_kind['nn']:.3f} {by_kind['map']:.3f} "
                  f"{by_kind['top5']:.3f}                   {by_library['nn']:.3f} "
                  f"{by_library['map']:.3f} {by_library['top5']:.3f}")
            if family == "ss9" and order == "service":
                service_keys = keys
    assert service_keys is not None
    answers = first_answers(service_keys, kinds)
    print("ss9 in the service's order, first answers by kind:")
    for kind, row in answers.items():
        print(f"  {kind:32s} {row['right']:3d} / {row['parts']:3d}  {row['taken_for'] or ''}")
    report["first_answers"] = answers
    if args.json:
        args.json.write_text(json.dumps(report, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
