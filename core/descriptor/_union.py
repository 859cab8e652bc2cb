"""The descriptor as an ordered union of weighted blocks.

Like scikit-learn's ``FeatureUnion``: each block measures the sample on its own, is
multiplied by its weight, and the blocks are joined in layout order; the whole is scaled to
unit norm (so L2 distance and inner product rank alike in FAISS) and stored as float32. A
block of weight 0, or with nothing to measure (no WKS energies, no eigenvalue channel), is
left out.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from core.descriptor._block import Block, unit_block
from core.descriptor._sample import Sample
from core.descriptor._signature import SignatureGrid
from core.descriptor._version import descriptor_version
from core.descriptor.blocks.caps import CapsBlock
from core.descriptor.blocks.distances import D1Block, D2Block
from core.descriptor.blocks.local import LocalBlock
from core.descriptor.blocks.normals import NormalsBlock
from core.descriptor.blocks.ring import RingBlock
from core.descriptor.blocks.spectral import DnaBlock, HksBlock, SlopeBlock, WksBlock
from core.descriptor.blocks.symmetry import SymmetryBlock
from core.settings import DescriptorSettings, EngineSettings

__all__ = ["BLOCK_WEIGHTS", "DescriptorSpec"]

#: Every block of the layout by name (``DescriptorSpec.blocks``), in layout order, and the
#: ``DescriptorSettings`` field that weighs it.
BLOCK_WEIGHTS: dict[str, str] = {
    "hks": "hks_weight", "wks": "wks_weight", "slope": "wks_slope_weight", "dna": "dna_weight",
    "d2": "d2_weight", "d1": "d1_weight", "normals": "normal_weight",
    "symmetry": "symmetry_weight", "ring": "ring_weight", "caps": "caps_weight",
    "local": "local_weight",
}


@dataclass(frozen=True)
class DescriptorSpec:
    """The signature grid and the weighted blocks of one database's descriptor.

    Build it with ``from_settings``; it only holds parameters.

    Attributes
    ----------
    grid : SignatureGrid
        Heat times and wave energies of the per-point signature.
    parts : tuple of (Block, float)
        Every block in layout order with its weight (0: left out of the vector).
    normal_neighbours : int
        The sample's normals: local PCA of this many nearest points.
    runs_longest : float or None
        The extrinsic blocks measure the part with its runs of one cross-section longer
        than this many radii shortened to it (``Sample``); None: the part as it is.
    family : str
        The descriptor family (``core.settings.DESCRIPTOR_FAMILIES``).
    """

    grid: SignatureGrid
    parts: tuple[tuple[Block, float], ...]
    normal_neighbours: int = 12
    runs_longest: float | None = None
    family: str = "parts"

    def __post_init__(self) -> None:
        names = [block.name for block, _ in self.parts]
        if len(set(names)) != len(names):
            raise ValueError(f"block names must be unique, not {names}")

    @classmethod
    def from_settings(cls, settings: DescriptorSettings) -> DescriptorSpec:
        """The spec of ``settings``, validated.

        Raises
        ------
        SettingsError
            Invalid settings, or a local block whose vocabulary is missing or was fitted on
            other columns than these settings give (another time grid needs its own
            vocabulary, or ``local_weight=0``).
        """
        settings.validate()
        grid = SignatureGrid.from_settings(settings)
        times, energies, bins = len(grid.times), len(grid.energies), settings.bins
        local = LocalBlock(settings.local_encoding, settings.local_vocabulary,
                           settings.local_columns, tuple(settings.local_neighbours))
        if settings.local_weight > 0:
            local.check(times, energies)
        parts: tuple[tuple[Block, float], ...] = (
            (HksBlock(times, bins, settings.hks_range), settings.hks_weight),
            (WksBlock(energies, bins, settings.wks_log_range), settings.wks_weight),
            # No slope without two energies: its weight is then 0 (in the version too).
            (SlopeBlock(energies, bins), settings.wks_slope_weight if energies > 1 else 0.0),
            (DnaBlock(settings.dna_count), settings.dna_weight),
            (D2Block(bins, settings.d2_pairs), settings.d2_weight),
            (D1Block(bins), settings.d1_weight),
            (NormalsBlock(), settings.normal_weight),
            (SymmetryBlock(), settings.symmetry_weight),
            (RingBlock(), settings.ring_weight),
            (CapsBlock(settings.caps_bins, settings.caps_depth), settings.caps_weight),
            (local, settings.local_weight),
        )
        return cls(grid, parts, settings.normal_neighbours, settings.runs_longest,
                   settings.family)

    def with_block(self, block: Block, weight: float) -> DescriptorSpec:
        """This spec with ``block`` at ``weight``: in the place of the block of that name,
        or appended at the end."""
        parts = [(block, weight) if old.name == block.name else (old, w)
                 for old, w in self.parts]
        if block.name not in self.names:
            parts.append((block, weight))
        return replace(self, parts=tuple(parts))

    @property
    def names(self) -> tuple[str, ...]:
        """Every block's name, in layout order (those left out too)."""
        return tuple(block.name for block, _ in self.parts)

    def block(self, name: str) -> Block:
        """The block called ``name``.

        Raises
        ------
        KeyError
            No such block.
        """
        for block, _ in self.parts:
            if block.name == name:
                return block
        raise KeyError(name)

    def weight(self, name: str) -> float:
        """The weight of the block called ``name`` (``KeyError``: no such block)."""
        return {block.name: weight for block, weight in self.parts}[name]

    @property
    def active(self) -> tuple[tuple[Block, float], ...]:
        """The blocks in the vector, in layout order, with their weights."""
        return tuple((block, weight) for block, weight in self.parts
                     if weight > 0 and block.width > 0)

    @property
    def widths(self) -> dict[str, int]:
        """Each block in the vector by name, in layout order, and its width; they sum to the
        vector's width."""
        return {block.name: block.width for block, _ in self.active}

    @property
    def extrinsic(self) -> bool:
        """True when a block measured on the embedding (how the surface sits in space:
        D2, D1, normals, symmetry, ring, caps) is in the vector."""
        return any(block.extrinsic for block, _ in self.active)

    def signature(self, eigenvalues: np.ndarray, eigenvectors: np.ndarray) -> np.ndarray:
        """Per-point signature, ``(n, s) float``: log HKS per time, then log WKS per energy
        (``SignatureGrid.signature``)."""
        return self.grid.signature(eigenvalues, eigenvectors)

    def sample(
        self,
        signature: np.ndarray,
        areas: np.ndarray,
        eigenvalues: np.ndarray,
        points: np.ndarray | None = None,
    ) -> Sample:
        """What the blocks measure (see ``histogram`` for the parameters)."""
        return Sample(signature, areas, eigenvalues, points, hks_count=len(self.grid.times),
                      normal_neighbours=self.normal_neighbours,
                      runs_longest=self.runs_longest)

    def histogram(
        self,
        signature: np.ndarray,
        areas: np.ndarray,
        eigenvalues: np.ndarray,
        points: np.ndarray | None = None,
    ) -> np.ndarray:
        """The descriptor, ``(d,) float32`` of unit norm.

        Parameters
        ----------
        signature : (n, s) float
            From ``signature``.
        areas : (n,) float
            Area each point stands for.
        eigenvalues : (k,) float
            Unit-area eigenvalues, for the normalised eigenvalue channel.
        points : (n, 3) float, optional
            The points the signature was computed on (any position and scale); required
            when a block measures them (``extrinsic``, or local words with surface
            variation).

        Raises
        ------
        ValueError
            ``points`` missing, or not one per signature row, while a block needs them.
        """
        blocks = self.blocks(signature, areas, eigenvalues, points)
        return unit_block(np.concatenate(list(blocks.values()))).astype(np.float32)

    def blocks(
        self,
        signature: np.ndarray,
        areas: np.ndarray,
        eigenvalues: np.ndarray,
        points: np.ndarray | None = None,
    ) -> dict[str, np.ndarray]:
        """The weighted blocks of ``histogram`` by name, in layout order, before the whole is
        scaled to unit norm; blocks left out are not there. Same parameters.

        With every weight 1 they are the blocks as measured (unit norm, ``ring`` and
        ``symmetry`` raw) that a weight search recombines.
        """
        sample = self.sample(signature, areas, eigenvalues, points)
        return {block.name: weight * block.measure(sample) for block, weight in self.active}

    def version(self, settings: EngineSettings) -> str:
        """Everything that changes the vector, in one readable string closed by a digest of
        the exact values (``core.descriptor._version.descriptor_version``)."""
        return descriptor_version(self, settings)
