"""Builds the shipped local vocabularies, ``core/data/hks-sv64.npz`` and ``hks64.npz``.

A vocabulary is 64 k-means words of the local descriptors of every model of its fitting
sources (``research.study.fit_words``: seed 0, 200 points drawn per model, the sources in
name order), each model's descriptors as its family's settings take them:
``hks-sv64`` the ``parts`` family's (log HKS at 16 times, the surface variation at 10 and 30
neighbours: 18 columns), ``hks64`` the ``bendable`` family's (the log HKS alone: 16). The
shipped pair was fitted on the six sources of the first study (bendable, capod, gearworks,
generated, madcad, parts; ``local_features_select.py --write-vocabulary``).

Two steps: the slow one is stage 1 of every study (``python -m research.extract``: hours
for the six sources); the final one fits and saves (``words_of``, then ``--write``). The
file, not a refit, is what ships: its digest enters ``descriptor_version``, so a refit is a
new descriptor version and every catalogue is described again. A refit of today's sources
does not give the shipped words: the sources and the extraction have moved since (a
six-source fit of the 2026-11-29 extraction had digest ccf12e374c, the shipped hks-sv64
51a42f109a).

    python -m research.artefacts.vocabulary /work/study hks-sv64 [--write]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import core
from core.evaluation.variants import BENDABLE_WORDS_DESCRIPTOR
from core.local_features import Vocabulary
from core.settings import DESCRIPTOR_FAMILIES, DescriptorSettings
from research.study import Study, fit_words

__all__ = ["DATA", "FIRST_SIX", "VOCABULARIES", "words_of"]

#: The shipped vocabularies and the family whose local descriptors each one's words are of.
VOCABULARIES: dict[str, DescriptorSettings] = {
    "hks-sv64": DESCRIPTOR_FAMILIES["parts"], "hks64": BENDABLE_WORDS_DESCRIPTOR}
#: The shipped words' fitting sources.
FIRST_SIX = ("bendable", "capod", "gearworks", "generated", "madcad", "parts")
#: Where the package keeps them.
DATA = Path(core.__file__).resolve().parent / "data"


def words_of(study: Study, name: str, sources: tuple[str, ...] = FIRST_SIX) -> Vocabulary:
    """The vocabulary ``name`` fitted on ``sources`` of ``study``."""
    study.require(sources)
    features = study.features(VOCABULARIES[name])
    return fit_words([rows for source in study.names if source in sources
                      for rows in features[source]])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path, help="an extraction (python -m research.extract)")
    parser.add_argument("name", choices=sorted(VOCABULARIES))
    parser.add_argument("--sources", nargs="+", default=list(FIRST_SIX))
    parser.add_argument("--write", action="store_true", help="replace the shipped file")
    args = parser.parse_args(argv)
    vocabulary = words_of(Study(args.out), args.name, tuple(args.sources))
    shipped = DATA / f"{args.name}.npz"
    print(f"{args.name} from {', '.join(args.sources)}: digest {vocabulary.digest()} "
          f"(shipped {Vocabulary.load(shipped).digest()})")
    if args.write:
        vocabulary.save(shipped)
        print(f"wrote {shipped}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
