"""A labelled dataset laid out as ``DATASET_DIR/CLASS/MODEL_FILE``.

The folder name is the class. Byte-identical files (same SHA-256) are counted once: a
duplicate would be its own perfect nearest neighbour and inflate every score (capod's
Piano/m121.obj and m123.obj are the same file). A Princeton ``.cla`` file at the top level,
when present, is read as a cross-check of the folder labels.
"""

from __future__ import annotations

import hashlib
import random
from dataclasses import dataclass
from pathlib import Path

from core.io import SUPPORTED_FORMATS

__all__ = ["Dataset", "Model", "file_sha256", "load_dataset", "read_cla"]


@dataclass(frozen=True)
class Model:
    """One model file of the dataset.

    Attributes
    ----------
    path : Path
    label : str
        Class (folder name).
    sha256 : str
        Hex digest of the file's bytes: identity for de-duplication and cache keys.
    """

    path: Path
    label: str
    sha256: str

    @property
    def name(self) -> str:
        return f"{self.label}/{self.path.name}"


@dataclass
class Dataset:
    """The models kept, and what was left out.

    Attributes
    ----------
    root : Path
    models : list of Model
        Sorted by class, then file name.
    duplicates : list of (str, str)
        ``(dropped, kept)`` model names of byte-identical files.
    cla_mismatches : list of str
        Models whose ``.cla`` class differs from their folder (empty without a ``.cla``).
    """

    root: Path
    models: list[Model]
    duplicates: list[tuple[str, str]]
    cla_mismatches: list[str]

    @property
    def labels(self) -> list[str]:
        return [model.label for model in self.models]


def file_sha256(path: Path) -> str:
    """SHA-256 hex digest of a file's bytes."""
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for chunk in iter(lambda: handle.read(1 << 20), b""):
            digest.update(chunk)
    return digest.hexdigest()


def read_cla(path: Path) -> dict[str, str]:
    """Model id -> class name from a Princeton Shape Benchmark ``.cla`` file.

    Layout: ``PSB 1``, ``n_classes n_models``, then per class a line ``name parent count``
    followed by ``count`` model ids.
    """
    tokens = path.read_text().split("\n")
    lines = [line.split() for line in tokens]
    labels: dict[str, str] = {}
    row = 2
    while row < len(lines):
        fields = lines[row]
        row += 1
        if len(fields) != 3 or not fields[2].isdigit():
            continue
        name, count = fields[0], int(fields[2])
        taken = 0
        while taken < count and row < len(lines):
            if lines[row]:
                labels[lines[row][0]] = name
                taken += 1
            row += 1
    return labels


def _model_id(path: Path) -> str:
    """capod names files ``m<id>.obj``; the ``.cla`` lists the bare id."""
    stem = path.stem
    return stem[1:] if stem[:1] == "m" and stem[1:].isdigit() else stem


def load_dataset(
    root: str | Path, limit_per_class: int | None = None, subset_seed: int = 0
) -> Dataset:
    """Walk ``root/CLASS/MODEL_FILE`` and de-duplicate by content.

    Parameters
    ----------
    root : path
    limit_per_class : int, optional
        Keep a seeded random subset of this many models per class (after de-duplication),
        for quick runs; the same seed gives the same subset, so caches stay valid.
    subset_seed : int

    Returns
    -------
    Dataset
    """
    root = Path(root)
    extensions = {f".{ext}" for ext in SUPPORTED_FORMATS}
    seen: dict[str, Model] = {}
    duplicates: list[tuple[str, str]] = []
    by_class: dict[str, list[Model]] = {}
    for folder in sorted(p for p in root.iterdir() if p.is_dir()):
        for path in sorted(folder.iterdir()):
            if path.suffix.lower() not in extensions or not path.is_file():
                continue
            model = Model(path=path, label=folder.name, sha256=file_sha256(path))
            if model.sha256 in seen:
                duplicates.append((model.name, seen[model.sha256].name))
                continue
            seen[model.sha256] = model
            by_class.setdefault(folder.name, []).append(model)
    if limit_per_class is not None:
        rng = random.Random(subset_seed)
        by_class = {
            label: sorted(rng.sample(models, min(limit_per_class, len(models))),
                          key=lambda m: m.path.name)
            for label, models in by_class.items()
        }
    models = [model for label in sorted(by_class) for model in by_class[label]]
    mismatches: list[str] = []
    cla_files = sorted(root.glob("*.cla"))
    if cla_files:
        cla = read_cla(cla_files[0])
        mismatches = [
            m.name for m in models if cla.get(_model_id(m.path), m.label) != m.label
        ]
    return Dataset(root=root, models=models, duplicates=duplicates, cla_mismatches=mismatches)
