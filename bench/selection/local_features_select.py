"""Stage 2 of the engineering-parts study (issue 24): choose the descriptor by a fixed rule.

Reads the per-model features of ``bench/selection/local_features_extract.py`` and scores every
candidate descriptor on every source, leave-one-out within the source (PSB conventions,
``core.evaluation.metrics``).

Candidates: a base (``ss4``, the present default with its extrinsic blocks, or ``spectral``,
the intrinsic previous default) alone, or joined with a local block (``core.local_features``:
``bof`` or ``vlad`` encoding; local features ``sig`` = the 32-column signature, ``sig+sv``
with surface variation at 10 and 30 neighbours, ``hks`` (the 16 HKS columns) or ``hks+sv``;
vocabularies of 16, 32 or 64 words) at weight 0.25, 0.5, 1, 2 or 4 next to the base's weighted
blocks (as ``DescriptorSpec`` joins them: the whole is scaled to unit norm once), or alone
(base ``none``). ``ss4-half`` is ``ss4`` with its extrinsic blocks at half
weight; ``ss4-nospread``, ``ss4-noprop`` and ``spectral+nrm+sym`` were added in a second
round, after the first round's per-class scores (see ``BASES``); the rule and its
leave-one-source-out figures cover the whole grid. Candidates with an extrinsic part (any
base but ``spectral`` and ``none``, or surface variation) are for rigid parts only.

The rule, written down before any score was seen:

1. A source's score is its mAP. A vocabulary that scores source ``s`` is fitted on every
   source but ``s`` (leave-one-source-out), so no source is encoded by words made from it.
2. The default is the candidate with the highest mean score over all sources, each source
   weighing the same; candidates within 0.002 of the best go to the one with the shorter
   vector.
3. The generalisation figure of the rule: for each source ``s``, the candidate the rule
   picks from the other sources alone, scored on ``s``.
4. For bendable shapes, the same rule among intrinsic candidates (base ``spectral`` or
   ``none``, local features ``sig`` or ``hks``) on the non-rigid sources only
   (``bendable`` and capod's Human, Hand, Dog, Horse, Spider classes), kept only if its
   mean over all sources is not below ``spectral``'s.

    .venv/bin/python bench/selection/local_features_select.py OUT [--json RESULT.json]
"""

from __future__ import annotations

import argparse
import itertools
import json
import os
from dataclasses import dataclass
from pathlib import Path

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import numpy as np  # noqa: E402

from core.evaluation.metrics import pairwise_distances, ranked_relevance, score_rankings  # noqa: E402
from core.evaluation.variants import SPECTRAL_DESCRIPTOR, SS4_DESCRIPTOR  # noqa: E402
from core.local_features import Vocabulary, encode_bof, encode_vlad, local_descriptors  # noqa: E402
from core.settings import DescriptorSettings  # noqa: E402

NON_RIGID_CAPOD = ("Human", "Hand", "Dog", "Horse", "Spider")
NEIGHBOURS = (10, 30)
WORDS = (16, 32, 64)
WEIGHTS = (0.25, 0.5, 1.0, 2.0, 4.0)
FEATURES = ("sig", "hks", "sig+sv", "hks+sv")
INTRINSIC_FEATURES = ("sig", "hks")
ENCODINGS = ("bof", "vlad")
_SPECTRAL = ("hks", "wks", "slope", "dna")


def _weights(settings: DescriptorSettings) -> dict[str, float]:
    return {
        "hks": settings.hks_weight, "wks": settings.wks_weight,
        "slope": settings.wks_slope_weight, "dna": settings.dna_weight,
        "d2": settings.d2_weight, "spread": settings.spread_weight, "d1": settings.d1_weight,
        "normals": settings.normal_weight, "symmetry": settings.symmetry_weight,
        "axes": settings.axis_weight,
    }


def _halved(weights: dict[str, float]) -> dict[str, float]:
    extrinsic = ("d2", "spread", "d1", "normals", "symmetry", "axes")
    return {key: value / 2 if key in extrinsic else value for key, value in weights.items()}


_SS4 = _weights(SS4_DESCRIPTOR)
BASES = {
    "ss4": _SS4,
    "ss4-half": _halved(_SS4),
    # Second round (after a first look at per-class scores: the proportion blocks split
    # screws of one head type by length): ss4 without the proportion-sensitive blocks, and
    # the spectral base with the two extrinsic blocks that do not grow with proportions.
    "ss4-nospread": {**_SS4, "spread": 0.0},
    "ss4-noprop": {**_SS4, "spread": 0.0, "axes": 0.0},
    "spectral+nrm+sym": {**_weights(SPECTRAL_DESCRIPTOR), "normals": 0.5, "symmetry": 1.0},
    "spectral": _weights(SPECTRAL_DESCRIPTOR),
    "none": {},
}
#: Bases that see only the spectrum.
INTRINSIC_BASES = ("spectral", "none")


@dataclass
class Source:
    name: str
    labels: list[str]
    names: list[str]
    bases: dict[str, np.ndarray]  # base -> (m, d) unit rows
    local: dict[str, list[np.ndarray]]  # feature set -> per model (n, d)
    areas: list[np.ndarray]


def _unit_rows(rows: np.ndarray) -> np.ndarray:
    return rows / np.maximum(np.linalg.norm(rows, axis=1, keepdims=True), 1e-300)


def joined(base: np.ndarray, block: np.ndarray | None, weight: float) -> np.ndarray:
    """A candidate's unit rows: the base's weighted blocks ``(m, d)``, then the local block
    ``(m, b)`` times ``weight`` (none: the base alone), as ``DescriptorSpec`` joins them."""
    return _unit_rows(base if block is None else np.hstack([base, weight * block]))


def load_source(folder: Path) -> Source:
    labels, names, areas = [], [], []
    base_rows: dict[str, list[np.ndarray]] = {name: [] for name in BASES}
    local: dict[str, list[np.ndarray]] = {name: [] for name in FEATURES}
    for path in sorted(folder.glob("*.npz")):
        with np.load(path) as data:
            labels.append(str(data["label"]))
            names.append(str(data["name"]))
            areas.append(data["areas"])
            for base, weights in BASES.items():
                parts = [weights[key] * data[f"blocks_{key}"] for key in weights
                         if weights[key] > 0 and f"blocks_{key}" in data.files]
                base_rows[base].append(np.concatenate(parts) if parts else np.zeros(0))
            signature = data["signature"].astype(np.float64)
            local["sig"].append(signature)
            local["hks"].append(signature[:, : signature.shape[1] // 2])
            with_variation = local_descriptors(
                signature, data["points"].astype(np.float64), NEIGHBOURS
            )
            local["sig+sv"].append(with_variation)
            hks_columns = signature.shape[1] // 2  # 16 HKS times, then 16 WKS energies
            local["hks+sv"].append(np.hstack(
                [with_variation[:, :hks_columns], with_variation[:, signature.shape[1]:]]
            ))
    # Raw weighted blocks, as ``DescriptorSpec.histogram`` joins them: a local block's weight
    # is relative to these, and the whole is scaled to unit norm once.
    bases = {name: np.array(rows) for name, rows in base_rows.items()}
    return Source(folder.name, labels, names, bases, local, areas)


def nonrigid_rows(source: Source) -> list[int]:
    """The rows of capod's non-rigid classes in ``source`` (capod)."""
    return [i for i, label in enumerate(source.labels) if label in NON_RIGID_CAPOD]


def split_capod(source: Source) -> list[Source]:
    """capod's non-rigid classes as a source of their own (scored within themselves)."""
    keep = nonrigid_rows(source)
    return [Source(
        "capod-nonrigid",
        [source.labels[i] for i in keep], [source.names[i] for i in keep],
        {name: rows[keep] for name, rows in source.bases.items()},
        {name: [rows[i] for i in keep] for name, rows in source.local.items()},
        [source.areas[i] for i in keep],
    )]


@dataclass
class Study:
    """Every source of one study folder (``OUT/features/<kind>``), as the selectors use them.

    ``sources`` are the rule's, one per folder of ``folders``; ``scored`` adds
    capod-nonrigid, which is scored apart.
    """

    folders: list[Path]
    sources: list[Source]

    @property
    def scored(self) -> list[Source]:
        capod = [s for s in self.sources if s.name == "capod"]
        return self.sources + (split_capod(capod[0]) if capod else [])

    def with_nonrigid(self, per_source: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        """``per_source`` (rows per source) with capod-nonrigid's rows added, when capod is
        there; the same dict, for chaining."""
        capod = [s for s in self.sources if s.name == "capod"]
        if capod and "capod" in per_source:
            per_source["capod-nonrigid"] = per_source["capod"][nonrigid_rows(capod[0])]
        return per_source


def load_study(folder: Path) -> Study:
    """The sources of ``folder`` (one sub-folder of feature files each), sorted by name."""
    folders = [path for path in sorted(folder.iterdir()) if path.is_dir()]
    return Study(folders, [load_source(path) for path in folders])


def score(vectors: np.ndarray, labels: list[str]) -> dict[str, float]:
    distances = pairwise_distances(vectors, vectors)
    relevance = ranked_relevance(distances, labels, labels, np.eye(len(labels), dtype=bool))
    return score_rankings(relevance)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--kind", default="clean")
    parser.add_argument("--json", type=Path)
    parser.add_argument("--write-vocabulary", type=Path, metavar="DIR",
                        help="fit the chosen candidates' vocabulary on every source and "
                             "write it to DIR/<features><words>.npz (core/data ships it)")
    args = parser.parse_args(argv)
    folder = args.out / "features" / args.kind
    sources = [load_source(path) for path in sorted(folder.iterdir()) if path.is_dir()]
    fitting = {source.name: source for source in sources}
    scored = list(sources)
    if "capod" in fitting:
        scored += split_capod(fitting["capod"])
    print("sources:", {s.name: len(s.labels) for s in scored})

    # Local blocks per (features, words, encoding), each source encoded by a vocabulary
    # fitted on the other sources (capod-nonrigid counts as capod).
    local_blocks: dict[tuple[str, int, str], dict[str, np.ndarray]] = {}
    cache = args.out / "local_blocks" / args.kind
    cache.mkdir(parents=True, exist_ok=True)
    for features, words in itertools.product(FEATURES, WORDS):
        for source in sources:
            others = [s for s in sources if s.name != source.name]
            # Cached per (features, words, source, the sources fitted on and their sizes).
            key = f"{features}-{words}-{source.name}-" + "-".join(
                f"{s.name}{len(s.labels)}" for s in others)
            path = cache / f"{key}.npz"
            if path.exists():
                with np.load(path) as stored:
                    for encoding in ENCODINGS:
                        local_blocks.setdefault((features, words, encoding), {})[
                            source.name] = stored[encoding]
                continue
            fitting_rows = [rows for s in others for rows in s.local[features]]
            vocabulary = Vocabulary.fit(fitting_rows, words, seed=0, per_model=200)
            encoded = {}
            for encoding in ENCODINGS:
                encode = encode_bof if encoding == "bof" else encode_vlad
                encoded[encoding] = np.array([
                    encode(f, a, vocabulary)
                    for f, a in zip(source.local[features], source.areas, strict=True)
                ])
                local_blocks.setdefault((features, words, encoding), {})[source.name] = (
                    encoded[encoding])
            np.savez(path, **encoded)
        print("vocabularies done:", features, words, flush=True)
    for per_source in local_blocks.values():
        if "capod" in per_source:
            capod = fitting["capod"]
            keep = [i for i, label in enumerate(capod.labels) if label in NON_RIGID_CAPOD]
            per_source["capod-nonrigid"] = per_source["capod"][keep]

    candidates: dict[str, dict[str, object]] = {}
    for base in BASES:
        if base != "none":
            candidates[base] = {"base": base, "local": None, "weight": 0.0}
        for (features, words, encoding), weight in itertools.product(local_blocks, WEIGHTS):
            if base == "none" and weight != 1.0:
                continue  # alone, the local block's weight does not matter
            name = f"{base}+{encoding}-{features}-{words}w{weight:g}"
            candidates[name] = {"base": base, "local": (features, words, encoding),
                                "weight": weight}

    table: dict[str, dict[str, dict[str, float]]] = {}
    widths: dict[str, int] = {}
    for name, spec in candidates.items():
        table[name] = {}
        for source in scored:
            block = (None if spec["local"] is None
                     else local_blocks[spec["local"]][source.name])  # type: ignore[index]
            vectors = joined(source.bases[str(spec["base"])], block, float(spec["weight"]))
            widths[name] = vectors.shape[1]
            table[name][source.name] = score(vectors, source.labels)

    names_all = [s.name for s in sources]  # the rule's sources (capod once)
    mean = {c: float(np.mean([table[c][s]["map"] for s in names_all])) for c in table}

    def choose(pool: list[str], over: list[str]) -> str:
        means = {c: float(np.mean([table[c][s]["map"] for s in over])) for c in pool}
        best = max(means.values())
        close = [c for c in pool if means[c] >= best - 0.002]
        return min(close, key=lambda c: (widths[c], -means[c]))

    chosen = choose(list(table), names_all)
    loso = {s: choose(list(table), [o for o in names_all if o != s]) for s in names_all}
    non_rigid = [s for s in ("bendable", "capod-nonrigid") if s in table[chosen]]
    intrinsic = [c for c, spec in candidates.items() if spec["base"] in INTRINSIC_BASES
                 and (spec["local"] is None or spec["local"][0] in INTRINSIC_FEATURES)]
    bendable = choose(intrinsic, non_rigid) if non_rigid else "spectral"
    if mean[bendable] < mean["spectral"]:
        bendable = "spectral"

    header = ["candidate", "mean mAP", *[s.name for s in scored]]
    print("| " + " | ".join(header) + " |")
    print("|" + "---|" * len(header))
    ranked = sorted(table, key=lambda c: -mean[c])
    shown = ranked[:12] + [c for c in ("ss4", "spectral", bendable) if c not in ranked[:12]]
    for c in shown:
        cells = [f"{table[c][s.name]['map']:.3f} / {table[c][s.name]['nn']:.3f}" for s in scored]
        print(f"| {c} | {mean[c]:.3f} | " + " | ".join(cells) + " |")
    print(f"\nrule's choice: {chosen} (mean mAP {mean[chosen]:.3f}, width {widths[chosen]})")
    print("leave-one-source-out (choice without s -> its score on s; ss4 on s):")
    for s, c in loso.items():
        print(f"  {s}: {c} -> mAP {table[c][s]['map']:.3f} NN {table[c][s]['nn']:.3f} "
              f"(ss4 {table['ss4'][s]['map']:.3f} / {table['ss4'][s]['nn']:.3f})")
    print(f"bendable choice: {bendable}: " + ", ".join(
        f"{s} {table[bendable][s]['map']:.3f} (spectral {table['spectral'][s]['map']:.3f})"
        for s in non_rigid))
    if args.write_vocabulary:
        for name in dict.fromkeys([chosen, bendable]):
            spec = candidates[name]
            if spec["local"] is None:
                continue
            features, words, _ = spec["local"]  # type: ignore[misc]
            rows = [r for source in sources for r in source.local[features]]
            vocabulary = Vocabulary.fit(rows, words, seed=0, per_model=200)
            path = args.write_vocabulary / f"{features.replace('+', '-')}{words}.npz"
            vocabulary.save(path)
            print(f"wrote {path} (digest {vocabulary.digest()}) for {name}")
    if args.json:
        args.json.write_text(json.dumps({
            "table": table, "mean": mean, "chosen": chosen, "loso": loso,
            "bendable": bendable, "widths": widths,
        }, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
