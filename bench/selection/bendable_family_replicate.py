"""Issue 24: the ``bendable`` family's question, decided on two extractions no one has seen.

Why: the family (``spectral`` and idf counts of 64 HKS words at weight 2) was chosen by
rule 4 on plain distances. Asked again in the search service's order
(``bendable_order_select.py``) over five extractions (seeds 0-4, all read before this file
was written), fewer words scored higher on the two non-rigid sources left out every time
(+0.005 .. +0.040), with the 95 % interval above zero on three of five, and the FAUST-like
``poses`` check agreed (``spectral`` 0.964 against the family's 0.952). The script's second
test (the choice's mean over all eight sources not below the family's) allows no tie, and
over the five extractions the two means differed by -0.003 .. +0.003: a coin the draw
tosses. Every other test of issue 24 treats a difference within 0.002 as a tie. The issue's
target for bendable shapes is "with the descriptor the README recommends for bendable
shapes, not below ``spectral``" on FAUST and TOSCA, which the family risks.

So the question is asked once more, on extractions that no reading has seen (sample seeds 5
and 6, rotation seeds ``ROTATION_SEED + 5``, ``+ 6``; the same models), with the second
test's tie stated here, before either extraction exists (disclosed: the tie is the change,
made after seeds 0-4 were read; the rest of the rule is ``bendable_order_select.py``'s,
unchanged, and it runs unchanged on each extraction).

The rule (this file decides; nothing else is looked at first):

1. The rule's choice is the same candidate on both extractions, and it is not the family.
2. On each extraction its left-out mean on the two non-rigid sources is above the family's
   by more than the tie (0.002) with the 95 % paired bootstrap interval above zero
   (``bendable_order_select.py``'s first test, unchanged).
3. Its mean over the eight sources, averaged over the two extractions, is not below the
   family's by more than the tie (0.002).

If all three hold, the family becomes the choice (adopted in a later step with its tests,
the bend check and the ``poses`` check reported). Otherwise the family stays, and the risk
stays stated in the README and docs/results.md.

    for seed in 5 6; do
      .venv/bin/python bench/selection/local_features_extract.py /work/tuning /work/seed$seed \\
          --seed $seed --only madcad gearworks vslot parts generated bendable capod
      .venv/bin/python bench/selection/local_features_extract.py /work/tuning-mcad \\
          /work/seed$seed --seed $seed
      nice -n 5 .venv/bin/python bench/selection/bendable_order_select.py /work/seed$seed \\
          --json /work/seed$seed/bendable_order.json
    done
    .venv/bin/python bench/selection/bendable_family_replicate.py \\
        /work/seed5/bendable_order.json /work/seed6/bendable_order.json

**Result** (2026-11-28, seventeenth session; docs/results.md, "The ``bendable`` family's
question on two extractions no one had seen"): the family stays. The choice is ``spectral``
on both (test 1), the mean of eight over the two is 0.8037 against the family's 0.8048
(test 3 holds), but the left-out interval reaches below zero on both: +0.0110 (-0.0024 ..
+0.0262), +0.0032 (-0.0034 .. +0.0102) (test 2 fails). Disclosed: this machine's
``/work/tuning-mcad`` also held ``poses``; its features were moved out of the study folder
before the selectors ran, so the study is the same eight sources as on seeds 0-4.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bendable_order_select import SHIPPED  # noqa: E402
from extraction_select import NON_RIGID_SOURCES  # noqa: E402
from profile_block_select import TIE  # noqa: E402

#: The eight tuning sources whose mean is the second test's (capod-nonrigid is a subset of
#: capod, scored for the first test only).
EIGHT = ("madcad", "gearworks", "vslot", "parts", "generated", "bendable", "capod", "mcad")


def mean_of_eight(report: dict, candidate: str) -> float:
    """``candidate``'s mean mAP over the eight sources in one extraction's report."""
    return float(np.mean([report["table"][candidate][s]["map"] for s in EIGHT]))


def read(reports: list[dict]) -> dict[str, object]:
    """The rule's three tests on the extractions' ``bendable_order_select.py`` reports."""
    choices = {str(r["chosen"]) for r in reports}
    chosen = choices.pop() if len(choices) == 1 else None
    same = chosen is not None and chosen != SHIPPED
    gains = [r[f"minus_{SHIPPED}"] for r in reports]
    left_out = same and all(point > TIE and low > 0 for point, low, _ in gains)
    eight = {c: float(np.mean([mean_of_eight(r, c) for r in reports]))
             for c in ({chosen, SHIPPED} if chosen else {SHIPPED})}
    level = same and eight[chosen] >= eight[SHIPPED] - TIE
    return {"choices": [r["chosen"] for r in reports], "test 1 same choice": same,
            "left out minus the family": gains, "test 2 left out": left_out,
            "mean of eight": eight, "test 3 mean of eight within the tie": level,
            "ships": bool(same and left_out and level)}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("reports", type=Path, nargs=2)
    args = parser.parse_args(argv)
    reports = [json.loads(path.read_text()) for path in args.reports]
    for path, report in zip(args.reports, reports, strict=True):
        point, low, high = report[f"minus_{SHIPPED}"]
        nonrigid = {c: round(float(np.mean([report["table"][c][s]["map"]
                                            for s in NON_RIGID_SOURCES])), 4)
                    for c in report["table"]}
        print(f"{path}: choice {report['chosen']}, left out minus the family {point:+.4f} "
              f"({low:+.4f} .. {high:+.4f}); non-rigid means {nonrigid}; mean of eight "
              + ", ".join(f"{c} {mean_of_eight(report, c):.4f}" for c in report["table"]))
    verdict = read(reports)
    print(json.dumps(verdict, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
