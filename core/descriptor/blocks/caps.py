"""The caps block: how each end of the part looks, in the part's own radius.

Each end's depth-radius profile along the first and the third principal axis, measured from
the end in the part's median radius (``core.extrinsic.end_profiles``): a socket head, a
countersink, a hub or a thread's end looks the same on a screw or shaft of any length. Each
axis is averaged over the directions it could take, by a kernel that narrows as the axis'
eigen-gap grows (``core.extrinsic.soft_axis_weights``), so that a part without a defined axis
(a cube, a square plate) does not change its ends from one sampling to the next.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from core.descriptor._block import Block, unit_block
from core.descriptor._sample import Sample
from core.extrinsic import CAPS_SHARPNESS, end_profiles

__all__ = ["CapsBlock", "caps_block"]


@dataclass(frozen=True)
class CapsBlock(Block):
    """The end profiles square-rooted, ``(4 * bins**2,)`` of unit norm.

    Parameters
    ----------
    bins : int
        Bins per coordinate (depth, radius) of each end's histogram.
    depth : float
        How deep an end reaches, in the part's median radius.
    sharpness : float
        The axis kernel's sharpness (``core.extrinsic.soft_axis_weights``).
    """

    name: ClassVar[str] = "caps"
    extrinsic: ClassVar[bool] = True
    tag: ClassVar[str | None] = "caps"

    bins: int = 6
    depth: float = 1.0
    sharpness: float = CAPS_SHARPNESS

    @property
    def width(self) -> int:
        return 4 * self.bins**2

    def measure(self, sample: Sample) -> np.ndarray:
        return caps_block(sample.body_points, sample.body_areas, self.bins, self.depth,
                          sharpness=self.sharpness)


def caps_block(points: np.ndarray, areas: np.ndarray, bins: int, depth: float,
               weight: float = 1.0, sharpness: float = CAPS_SHARPNESS) -> np.ndarray:
    """``CapsBlock``'s vector of ``points : (n, 3) float`` with ``areas : (n,) float``,
    times ``weight``, ``(4 * bins**2,) float``."""
    profiles = end_profiles(points, areas, bins, depth, sharpness)
    return weight * unit_block(np.sqrt(profiles))
