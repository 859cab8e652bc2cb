"""The sources of one extraction as a study reads them, and a candidate's rows.

A ``Study`` is the folder ``research.extract`` wrote (``OUT/features/<source>/``): its
sources in name order, each source's models in file order. A candidate is a
``DescriptorSettings``; its rows are the service's blocks of every model for those settings,
joined and scaled to unit norm as the service joins them, except the local block: a source
is never encoded by words fitted on it (the rule's first clause), so each source's local
block uses 64 words fitted on every *other* source (``Study.local_blocks``), and a catalogue
of several sources one vocabulary fitted on the rest (``Study.pooled_local``). The blocks of
every model are cached per settings under ``OUT/cache/research``.

capod's articulated classes are scored apart as ``capod-nonrigid`` (``Study.scored``); they
are not one of the rule's sources.
"""

from __future__ import annotations

import hashlib
from collections.abc import Iterator
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from core.descriptor import DescriptorSpec
from core.evaluation.sources import NON_RIGID
from core.local_features import Vocabulary, encode_bof, encode_vlad, local_descriptors
from core.settings import DescriptorSettings

__all__ = ["NONRIGID", "WORDS", "Model", "PerSource", "Source", "Study", "fit_words"]

#: The scored source of capod's articulated classes.
NONRIGID = "capod-nonrigid"
#: Words per vocabulary (the shipped vocabularies'), and how they are fitted.
WORDS = 64
PER_MODEL = 200

#: Rows ``(m, d)`` per source name.
PerSource = dict[str, np.ndarray]


@dataclass(frozen=True)
class Model:
    """One model of an extraction (``research.extract``)."""

    label: str
    points: np.ndarray
    areas: np.ndarray
    signature: np.ndarray
    eigenvalues: np.ndarray

    @classmethod
    def load(cls, path: Path) -> Model:
        with np.load(path) as data:
            return cls(str(data["label"]), data["points"], data["areas"], data["signature"],
                       data["eigenvalues"])


@dataclass(frozen=True)
class Source:
    """One source folder: its model files and their labels, in file order."""

    name: str
    files: tuple[Path, ...]
    labels: tuple[str, ...]

    @classmethod
    def load(cls, folder: Path) -> Source:
        files = tuple(sorted(folder.glob("*.npz")))
        labels = []
        for file in files:
            with np.load(file) as data:
                labels.append(str(data["label"]))
        return cls(folder.name, files, tuple(labels))

    def models(self) -> Iterator[Model]:
        return (Model.load(file) for file in self.files)


def fit_words(features: list[np.ndarray], words: int = WORDS) -> Vocabulary:
    """The vocabulary of ``features`` (one ``(n, d)`` array per model), fitted as every
    shipped vocabulary was: seed 0, 200 points drawn per model."""
    return Vocabulary.fit(features, words, seed=0, per_model=PER_MODEL)


def local_features(model: Model, settings: DescriptorSettings) -> np.ndarray:
    """A model's local descriptors ``(n, d)`` as ``settings`` take them (the service's
    ``DescriptorSpec.local_block``): the log HKS columns (or the whole signature), then the
    surface variation at ``local_neighbours``."""
    columns = (model.signature[:, : len(settings.hks_times)]
               if settings.local_columns == "hks" else model.signature)
    return local_descriptors(columns, model.points, settings.local_neighbours)


def blocks_of(model: Model, settings: DescriptorSettings) -> np.ndarray:
    """Every weighted block of ``model`` but the local one, joined ``(d,)``, as the service
    computes them for ``settings``."""
    spec = DescriptorSpec.from_settings(replace(settings, local_weight=0.0))
    blocks = spec.blocks(model.signature, model.areas, model.eigenvalues, model.points)
    return np.concatenate(list(blocks.values()))


def _unit_rows(rows: np.ndarray) -> np.ndarray:
    return rows / np.maximum(np.linalg.norm(rows, axis=1, keepdims=True), 1e-300)


def _key(*parts: object) -> str:
    return hashlib.sha256(repr(parts).encode()).hexdigest()[:16]


class Study:
    """The sources of ``OUT/features`` (``research.extract``), in name order."""

    def __init__(self, out: Path) -> None:
        folders = sorted(path for path in (out / "features").iterdir() if path.is_dir())
        self.sources = [Source.load(folder) for folder in folders]
        self.cache = out / "cache" / "research"
        self.cache.mkdir(parents=True, exist_ok=True)
        self._features: dict[tuple[str, ...], dict[str, list[np.ndarray]]] = {}

    @property
    def names(self) -> list[str]:
        """The rule's sources."""
        return [source.name for source in self.sources]

    def require(self, names: tuple[str, ...]) -> None:
        """Stop before scoring unless the study holds every source of ``names``."""
        missing = sorted(set(names) - set(self.names))
        if missing:
            raise SystemExit(f"the study lacks {missing}: stop")

    def _nonrigid_rows(self) -> list[int]:
        capod = next(s for s in self.sources if s.name == "capod")
        return [i for i, label in enumerate(capod.labels) if label in (NON_RIGID["capod"] or ())]

    @property
    def scored(self) -> dict[str, tuple[str, ...]]:
        """Every scored source's labels: the rule's sources, then capod-nonrigid."""
        labels = {source.name: source.labels for source in self.sources}
        if "capod" in labels:
            labels[NONRIGID] = tuple(labels["capod"][i] for i in self._nonrigid_rows())
        return labels

    def with_nonrigid(self, rows: PerSource) -> PerSource:
        """``rows`` with capod-nonrigid's added (when capod is there); the same dict."""
        if "capod" in rows:
            rows[NONRIGID] = rows["capod"][self._nonrigid_rows()]
        return rows

    def features(self, settings: DescriptorSettings) -> dict[str, list[np.ndarray]]:
        """Every model's local descriptors, per source (read once per kind of feature)."""
        kind = (settings.local_columns, *map(str, settings.local_neighbours))
        if kind not in self._features:
            self._features[kind] = {
                s.name: [local_features(model, settings) for model in s.models()]
                for s in self.sources}
        return self._features[kind]

    def _encoded(self, settings: DescriptorSettings, encoded: list[str], fitted: list[str]
                 ) -> PerSource:
        """The local blocks of the sources ``encoded``, on one vocabulary fitted on the
        sources ``fitted`` (cached per features, encoding and sources with their sizes)."""
        features = self.features(settings)
        sizes = [f"{name}{len(features[name])}" for name in fitted]
        kind = (settings.local_columns, settings.local_neighbours, settings.local_encoding)
        key = _key(kind, sizes)
        paths = {name: self.cache / f"local-{key}-{name}.npz" for name in encoded}
        if not all(path.exists() for path in paths.values()):
            vocabulary = fit_words([rows for name in fitted for rows in features[name]])
            encode = encode_vlad if settings.local_encoding == "vlad" else encode_bof
            areas = {s.name: [m.areas for m in s.models()] for s in self.sources
                     if s.name in encoded}
            for name, path in paths.items():
                np.savez(path, block=np.array([
                    encode(rows, weights, vocabulary)
                    for rows, weights in zip(features[name], areas[name], strict=True)]))
        blocks = {}
        for name, path in paths.items():
            with np.load(path) as stored:
                blocks[name] = stored["block"]
        return blocks

    def local_blocks(self, settings: DescriptorSettings) -> PerSource:
        """Each source's local block ``(m, b)``, encoded by words fitted on every other
        source, capod-nonrigid added."""
        blocks: PerSource = {}
        for name in self.names:
            blocks.update(self._encoded(settings, [name], [n for n in self.names if n != name]))
        return self.with_nonrigid(blocks)

    def pooled_local(self, settings: DescriptorSettings, pooled: tuple[str, ...]) -> PerSource:
        """The local blocks of the ``pooled`` sources as one catalogue encodes them: one
        vocabulary, fitted on every source not pooled."""
        return self._encoded(settings, list(pooled), [n for n in self.names if n not in pooled])

    def blocks(self, settings: DescriptorSettings) -> PerSource:
        """``blocks_of`` every model, ``(m, d)`` per source (cached per settings)."""
        key = _key(replace(settings, local_weight=0.0))
        rows: PerSource = {}
        for source in self.sources:
            path = self.cache / f"blocks-{key}-{source.name}{len(source.files)}.npy"
            if not path.exists():
                np.save(path, np.array([blocks_of(model, settings) for model in source.models()]))
            rows[source.name] = np.load(path)
        return rows

    def rows(self, settings: DescriptorSettings, names: tuple[str, ...] | None = None,
             local: PerSource | None = None) -> PerSource:
        """A candidate's unit rows per scored source (``names``: only those): its blocks
        and, at its ``local_weight``, the local block (``local``, else ``local_blocks``)."""
        blocks = self.with_nonrigid(self.blocks(settings))
        if settings.local_weight > 0:
            local = local if local is not None else self.local_blocks(settings)
            blocks = {name: np.hstack([rows, settings.local_weight * local[name]])
                      for name, rows in blocks.items() if name in local}
        return {name: _unit_rows(rows) for name, rows in blocks.items()
                if names is None or name in names}
