"""Issue 24 follow-up: the spectrum of the evened part in the parts family.

Measurement only (the service's descriptor does not change in this step; a choice that
passes every test below is adopted in a later step, with its tests, a new vocabulary and the
score calibration). Why: ``ss10`` and ``ss11`` took a kind's many lengths and proportions
out of the extrinsic blocks (D2, D1 on the sample with its principal spreads evened; the
evened surface's areas), and they are the one view of the parts since ``ss5`` that gained on
every third-party library at once (docs/results.md, "Distances apart from the proportions",
"Areas apart from the proportions"). The spectral side still sees the proportions first:
``screw_heads_report.py`` (twentieth session, after the verdict on ShapeDNA's weight) finds
ShapeDNA ranking a same-size screw of another head above the median screw of the query's
own head in 46 of 48 pairs, and the nineteenth session's check found the HKS, WKS and slope
histograms of one head at two lengths moving apart under evened areas (0.821 -> 0.917): the
shank's own signature changes with its length, and the issue's held-out kinds come in
"several standards and sizes". An area weight cannot take a length out of a spectrum; the
spectrum of the evened part can: the Laplace-Beltrami operator of the sample with its
principal spreads evened (``core.extrinsic.evened_spreads``, with the sample's areas),
rebuilt and solved with the same adaptive cutoff (the model's ``n`` is the evened part's).
Rotation, translation, uniform scale and point order do not change the evened sample beyond
the principal axes' signs, which no spectrum sees; it is not isometry-invariant (a bend moves
the spreads), so the ``bendable`` family keeps the part's own spectrum.

The grid, written before any score of it was seen (``local_features_extract.py
--evened-spectrum`` stores the evened part's points, areas, signature and blocks):

- ``ss11``, the reference: the service's descriptor, ranked in the service's order;
- ``dna``: ShapeDNA of the evened part, every other block ``ss11``'s (a second, 30-pair
  solve in the service);
- ``spectrum``: every spectral block of the evened part: the HKS, WKS and slope histograms,
  ShapeDNA and the local words (VLAD of its HKS and surface variation, over its own areas,
  each source encoded by words fitted on the other sources' evened parts, as every study's
  local block is); the extrinsic, ring and caps blocks ``ss11``'s (one solve, the evened
  part's in place of the part's).

Both at ``ss11``'s weights. Not asked: the histograms of the evened part beside the local
words of the part (two full solves: about 1.6x ``ss4``'s describe, above the issue's 1.5x).
Every candidate ranked in the search service's order (``core.rank.reciprocal``'s ``k1`` and
``lambda`` with the hub discount's keys, its first answer kept). The rule
(``evened_areas_select.close_study``): mean mAP over the eight sources (capod-nonrigid
scored apart), ties within 0.002 to the reference first, then the grid's order;
leave-one-source-out with a paired bootstrap over queries against ``ss11``. It ships only if

1. the leave-one-source-out mean is above ``ss11``'s by more than 0.002 with the 95 %
   interval above zero;
2. the four third-party libraries as one catalogue by kind: mAP not below ``ss11``'s, NN not
   below by more than 0.01;
3. the seed-0 choice, fixed, on seed 9 (``--confirm``; an extraction no score has read):
   its mean over the eight above ``ss11``'s by more than 0.002 with the 95 % paired interval
   above zero, and test 2 on that extraction;
4. after adoption, BOSL2 (no choice saw it) through ``shapesearch eval`` in the service's
   order: mAP not below the release's (0.7876) by more than 0.002, NN not below 0.950 by
   more than 0.01;
5. after adoption, single-view scans in scan mode (``core.evaluation.scan_retrieval``, the
   protocol of docs/results.md "Scans with ``ss11``", ``--kinds single+sor``): the mean of
   the seven sources not below ``ss11``'s in the same run by more than 0.01 (a partial
   view's spreads are not the part's);
6. ``bench/descriptor_cost.py``: the describe at most 1.5x ``ss4``'s.

Otherwise the adoption is reverted before it lands.

    .venv/bin/python bench/selection/local_features_extract.py /work/tuning /work/study8 \\
        --only madcad gearworks vslot parts generated bendable capod [--evened-spectrum]
    .venv/bin/python bench/selection/local_features_extract.py /work/tuning-mcad /work/study8 \\
        [--evened-spectrum]
    nice -n 5 .venv/bin/python bench/selection/evened_spectrum_select.py /work/study8 \\
        --json /work/study8/evened_spectrum.json
    # the same four extractions with --seed 9 into /work/seed9, then
    nice -n 5 .venv/bin/python bench/selection/evened_spectrum_select.py /work/seed9 \\
        --confirm "CHOICE" --json /work/seed9/evened_spectrum.json

**Result** (2026-11-28, twenty-second session, a 2-core AMD EPYC): declined. The evened
extraction held the study's models. Mean of eight: ``ss11`` 0.8927 (this machine's build;
0.8909 on the twenty-first session's), ``dna`` 0.8955 (py-gearworks 0.614 -> 0.626, our
generator 0.843 -> 0.852, MCAD 0.828 -> 0.834; bent shapes 0.992 -> 0.985), ``spectrum``
0.8759 (bd-vslot 0.915 -> 0.982, our generator 0.874, py-gearworks 0.642, MCAD NN 0.898 ->
0.932; pymadcad 0.963 -> 0.889, capod 0.989 -> 0.937, bent shapes 0.893). The rule picks
``dna``; without py-gearworks or our generator it keeps ``ss11``: left out **-0.0000 (95 %
-0.0015 .. +0.0014)**, test 1 fails (one catalogue by kind NN 0.877 level, mAP 0.718 ->
0.726). Seed 9 was not needed and not kept. After the verdict, per kind in the service's
order (``spectrum`` against ``ss11``): pymadcad's button, flat and hex heads 1.00 / 0.99 /
1.00 -> 0.62 / 0.68 / 0.81, capod's Human and Hand 1.00 / 0.98 -> 0.65 / 0.76, MCAD's spur and
helical gears 0.87 / 0.86 -> 0.54 / 0.57; bd-vslot's build plates and end caps 0.80 / 0.76 ->
1.00 / 1.00. The evening is one affine map of the whole part: shortening a screw shortens its
head too, so the heads' heights, which the spectrum tells them apart by, are squashed with
the length. The spectrum keeps the proportions as a kind's signature where the distances
could give them up.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")


sys.path.insert(0, str(Path(__file__).resolve().parent))
from evened_areas_rest_select import service_base  # noqa: E402
from evened_areas_select import PerSource, catalogue_scores, close_study, service_scores  # noqa: E402
from local_features_select import Study, load_study  # noqa: E402
from profile_block_select import (  # noqa: E402
    Replacing,
    default_local_blocks,
    stored_blocks,
    study_command,
)
from reciprocal_blend_select import SERVICE_ORDER  # noqa: E402

SS11 = "ss11"
#: The spectral base blocks each candidate takes from the evened part.
EVENED_KEYS = {"dna": ("dna",), "spectrum": ("hks", "wks", "slope", "dna")}


def evened_of(study: Study, out: Path) -> Study:
    """The evened parts' study beside ``study`` (``OUT/features/clean-evened``); stops
    unless it holds the same models of every source in the same order."""
    evened = load_study(out / "features" / "clean-evened")
    plain = {s.name: s.names for s in study.sources}
    if {s.name: s.names for s in evened.sources} != plain:
        raise SystemExit("the evened extraction does not hold the study's models: stop")
    print("the evened extraction holds the study's models", flush=True)
    return evened


class Candidates:
    """Each candidate's replaced base blocks and local block per source, built once."""

    def __init__(self, study: Study, evened: Study, cache: Path) -> None:
        self.study, self.evened = study, evened
        self.base = service_base(study)
        self.evened_blocks = {key: stored_blocks(evened, key)
                              for key in EVENED_KEYS["spectrum"]}
        # The words' cache keys name the sources, not their features: a folder of its own.
        local_cache = cache / "evened-spectrum"
        local_cache.mkdir(parents=True, exist_ok=True)
        self.evened_local = evened.with_nonrigid(
            default_local_blocks(evened.sources, local_cache))

    def replaced(self, name: str) -> dict[str, PerSource]:
        evened = {key: self.evened_blocks[key] for key in EVENED_KEYS.get(name, ())}
        return {**self.base, **evened}

    def local(self, name: str) -> PerSource | None:
        return self.evened_local if name == "spectrum" else None

    def catalogue(self, name: str, replacing: Replacing) -> dict[str, float]:
        """The four third-party libraries as one catalogue by kind, in the service's order
        (the words fitted on the other sources of the candidate's own kind)."""
        return catalogue_scores(self.study, replacing, self.replaced(name), order=SERVICE_ORDER,
                                words=self.evened if name == "spectrum" else None)

def main(argv: list[str] | None = None) -> int:
    args, study, cache = study_command(
        __doc__, argv, confirm="test 3: this candidate, fixed, against ss11")
    evened = evened_of(study, args.out)
    replacing = Replacing(study, cache)
    candidates = Candidates(study, evened, cache)
    print("blocks done", flush=True)
    names = (SS11, args.confirm) if args.confirm else (SS11, *EVENED_KEYS)
    table, queries = service_scores(
        study, ((name, replacing(candidates.replaced(name), local=candidates.local(name)))
                for name in names), SERVICE_ORDER)
    catalogue = {name: candidates.catalogue(name, replacing) for name in names}
    close_study("the spectrum of the evened part, parts family", SS11, table, queries,
                catalogue, [s.name for s in study.sources], args.confirm, args.json)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
