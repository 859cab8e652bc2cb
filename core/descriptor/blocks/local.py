"""The local block: every point's whole signature (and, for rigid parts, its surface
variation) pooled over a vocabulary shipped in ``core/data`` (``core.local_features``).

It keeps the detail that per-scale histograms drown: a screw's head, a flange's hub, a
gear's teeth are a few per cent of the surface.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import ClassVar

import numpy as np

from core.descriptor._block import Block
from core.descriptor._sample import Sample
from core.errors import SettingsError
from core.local_features import Vocabulary, encode_bof, encode_vlad, local_descriptors

__all__ = ["VOCABULARY_DIR", "LocalBlock", "load_vocabulary"]

#: Where the shipped vocabularies live (package data).
VOCABULARY_DIR = Path(__file__).resolve().parents[2] / "data"


@lru_cache(maxsize=8)
def load_vocabulary(name: str) -> Vocabulary:
    """The shipped vocabulary ``core/data/<name>.npz``, loaded once per process.

    Raises
    ------
    SettingsError
        No such vocabulary.
    """
    path = VOCABULARY_DIR / f"{name}.npz"
    if not name or not path.is_file():
        raise SettingsError(
            f"unknown local vocabulary {name!r} (looked for {path})", "local_vocabulary"
        )
    return Vocabulary.load(path)


@dataclass(frozen=True)
class LocalBlock(Block):
    """The points' local descriptors encoded on a vocabulary, unit norm: ``(words,)`` for a
    bag of words, ``(words * columns,)`` for VLAD.

    Parameters
    ----------
    encoding : {"vlad", "bof"}
        ``core.local_features.encode_vlad`` or ``encode_bof``.
    vocabulary : str
        The shipped vocabulary's name (``load_vocabulary``).
    columns : {"hks", "hks+wks"}
        Each point's log HKS at every time, or its whole signature (log WKS too).
    neighbours : tuple of int
        Neighbourhood sizes of the surface variation appended to each point's signature
        (``core.local_features.surface_variation``); empty: intrinsic, unchanged by bending.
    """

    name: ClassVar[str] = "local"

    encoding: str = "vlad"
    vocabulary: str = ""
    columns: str = "hks"
    neighbours: tuple[int, ...] = ()

    @property
    def width(self) -> int:
        words = load_vocabulary(self.vocabulary)
        return words.size * (words.width if self.encoding == "vlad" else 1)

    def measure(self, sample: Sample) -> np.ndarray:
        """Raises ``ValueError`` when the vocabulary does not fit the local descriptors."""
        vocabulary = load_vocabulary(self.vocabulary)
        columns = sample.log_hks if self.columns == "hks" else sample.signature
        points = sample.points if self.neighbours else None
        features = local_descriptors(columns, points, self.neighbours)
        if features.shape[1] != vocabulary.width:
            raise ValueError(
                f"vocabulary {self.vocabulary!r} has {vocabulary.width} columns, the "
                f"local descriptors {features.shape[1]}"
            )
        encode = encode_vlad if self.encoding == "vlad" else encode_bof
        return encode(features, sample.areas, vocabulary)

    def check(self, hks_count: int, wks_count: int) -> None:
        """Refuse a vocabulary fitted on other columns than a signature of ``hks_count``
        times and ``wks_count`` energies gives.

        Raises
        ------
        SettingsError
            The vocabulary is unknown, or its width differs (another time grid needs its
            own vocabulary, or no local block).
        """
        columns = hks_count + (wks_count if self.columns == "hks+wks" else 0)
        columns += len(self.neighbours)
        width = load_vocabulary(self.vocabulary).width
        if width != columns:
            raise SettingsError(
                f"local vocabulary {self.vocabulary!r} was fitted on {width} columns, these "
                f"settings give {columns} ({self.columns} with {hks_count} times): fit a "
                "vocabulary for them or set local_weight 0",
                "hks_times", "local_vocabulary", "local_weight",
            )
