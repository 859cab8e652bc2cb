"""The descriptor's blocks, one module per block or small family of blocks, in layout order:
``spectral`` (hks, wks, slope, dna), ``distances`` (d2, d1), ``normals``, ``symmetry``,
``ring``, ``caps``, ``local``."""

from core.descriptor.blocks.caps import CapsBlock, caps_block
from core.descriptor.blocks.distances import D1Block, D2Block, distance_distribution
from core.descriptor.blocks.local import VOCABULARY_DIR, LocalBlock, load_vocabulary
from core.descriptor.blocks.normals import NormalsBlock
from core.descriptor.blocks.ring import RingBlock, ring_block
from core.descriptor.blocks.spectral import DnaBlock, HksBlock, SlopeBlock, WksBlock
from core.descriptor.blocks.symmetry import SymmetryBlock

__all__ = [
    "VOCABULARY_DIR",
    "CapsBlock",
    "D1Block",
    "D2Block",
    "DnaBlock",
    "HksBlock",
    "LocalBlock",
    "NormalsBlock",
    "RingBlock",
    "SlopeBlock",
    "SymmetryBlock",
    "WksBlock",
    "caps_block",
    "distance_distribution",
    "load_vocabulary",
    "ring_block",
]
