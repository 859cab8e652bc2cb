"""The ring block: what repeats around a turned part (gear and sprocket teeth, bolt holes,
hex heads and sockets).

The angular spectrum about the first and the third principal axis, by three soft shells of
distance from the axis (``core.extrinsic.angular_spectrum``): 2 axes x 3 shells x 5 bands of
angular order, each value in [0, 1].
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from core.descriptor._block import Block
from core.descriptor._sample import Sample
from core.extrinsic import ANGULAR_BANDS, ANGULAR_SHELLS, SHELL_CENTRES, angular_spectrum

__all__ = ["RingBlock", "ring_block"]


@dataclass(frozen=True)
class RingBlock(Block):
    """The angular spectrum flattened, over the square root of its length, ``(30,)``.

    Not scaled to unit norm: each value is in [0, 1], so the block's norm is at most 1, and
    small when nothing repeats (a part with nothing repeating has a small block, and that is
    information).

    Parameters
    ----------
    shells : (3,) float
        The soft shells' centres, in the median distance from the axis
        (``core.extrinsic.SHELL_CENTRES``).
    """

    name: ClassVar[str] = "ring"
    extrinsic: ClassVar[bool] = True
    tag: ClassVar[str | None] = "ring"

    shells: tuple[float, float, float] = SHELL_CENTRES

    @property
    def width(self) -> int:
        return 2 * ANGULAR_SHELLS * len(ANGULAR_BANDS)

    def measure(self, sample: Sample) -> np.ndarray:
        return ring_block(sample.body_points, sample.body_areas, shell_centres=self.shells)


def ring_block(points: np.ndarray, areas: np.ndarray, weight: float = 1.0,
               shell_centres: tuple[float, float, float] = SHELL_CENTRES) -> np.ndarray:
    """``RingBlock``'s vector of ``points : (n, 3) float`` with ``areas : (n,) float``,
    times ``weight``, ``(30,) float``."""
    spectrum = angular_spectrum(points, areas, shell_centres).ravel()
    return weight * spectrum / np.sqrt(spectrum.size)
