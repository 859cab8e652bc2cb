"""Band bookkeeping of the banded shift-invert solver (Vallet & Levy 2008), as pure functions.

A shift-invert Lanczos call at shift s returns the k eigenvalues nearest s. With
R = max |lambda_i - s| it has found every eigenvalue in the open interval (s - R, s + R);
only eigenvalues tied at distance exactly R may be missing (on a sphere the 2l + 1 copies of
l(l + 1) are such ties). So if everything below a bound ``lower`` is already known and
s - R < lower, the band completes the spectrum up to s + R, except the cluster of eigenvalues
at the upper edge, which we drop as possibly partial. When s - R >= lower, an inertia count
at s can still prove that nothing lies in between (a band that fell into a spectral gap, as
between the multiplets of a sphere); otherwise the band is retried with a lower shift.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["BandSplit", "band_request", "next_shift", "split_band"]

# Where the next shift goes, as a share of the expected half-width of the band above the
# bound: 0.7 puts ~15% of the band below the bound (already known) as a safety margin
# against gap estimates that are too large, which would leave a hole and force a retry.
SHIFT_FRACTION = 0.7
# Eigenvalues within this share of (|s| + R) of the band edge (or of each other, chained)
# count as tied with the edge.
TIE_RTOL = 1e-6
# Extra eigenpairs asked of a band beyond the expected need, to absorb a dropped edge cluster.
_EXTRA = 4


@dataclass(frozen=True)
class BandSplit:
    """How one band's eigenvalues extend the known spectrum.

    Attributes
    ----------
    radius : float
        R = max |lambda_i - s|.
    missed_gap : bool
        s - R >= lower: eigenvalues between ``lower`` and s - R may be missing; retry lower.
    start, stop : int
        The new eigenvalues are ``values[start:stop]`` (empty when stop <= start).
    new_lower : float
        Everything below it is known once the new eigenvalues are added.
    """

    radius: float
    missed_gap: bool
    start: int
    stop: int
    new_lower: float

    @property
    def accepted(self) -> int:
        return max(self.stop - self.start, 0)

    def progressed(self, lower: float) -> bool:
        """The band added eigenvalues or at least raised the bound."""
        return not self.missed_gap and (self.accepted > 0 or self.new_lower > lower)


def split_band(
    values: np.ndarray, shift: float, lower: float, *, gap_certified: bool = False
) -> BandSplit:
    """Which eigenvalues of a band are new and certainly complete.

    Parameters
    ----------
    values : (k,) float
        Eigenvalues nearest ``shift``, ascending.
    shift : float
        s.
    lower : float
        Every eigenvalue below ``lower`` is already known.
    gap_certified : bool
        An inertia count showed that no eigenvalue lies in [lower, s - R]: the band is then
        complete from ``lower`` even when its window does not reach below it.

    Returns
    -------
    BandSplit
    """
    radius = float(np.max(np.abs(values - shift)))
    edge = shift + radius
    if shift - radius >= lower and not gap_certified:
        return BandSplit(radius, True, 0, 0, lower)
    tolerance = TIE_RTOL * (abs(shift) + radius)
    stop = values.size
    boundary = edge
    while stop > 0 and values[stop - 1] >= boundary - tolerance:
        boundary = values[stop - 1]
        stop -= 1
    start = int(np.searchsorted(values, lower, side="left"))
    first_unknown = values[stop] if stop < values.size else edge
    if stop <= start:
        # Nothing new, but the window may still prove that [lower, first_unknown) is empty.
        last_known = values[stop - 1] if stop > 0 else lower
        return BandSplit(
            radius, False, start, start, max(lower, 0.5 * (last_known + first_unknown))
        )
    return BandSplit(radius, False, start, stop, 0.5 * (values[stop - 1] + first_unknown))


def mean_gap(eigenvalues: np.ndarray, fallback: float) -> float:
    """Mean spacing of all known eigenvalues, lambda_max / (m - 1), or ``fallback``.

    Weyl's law makes lambda_k about linear in k, so the global slope is a steady estimate;
    the local spacing is not (on a sphere it is 0 inside a multiplet, 2(l + 1) between).

    Parameters
    ----------
    eigenvalues : (m,) float
        Known eigenvalues, ascending.
    fallback : float
        Returned with fewer than two eigenvalues or a non-positive slope.
    """
    if eigenvalues.size < 2:
        return fallback
    gap = float(eigenvalues[-1] - eigenvalues[0]) / (eigenvalues.size - 1)
    return gap if gap > 0 and math.isfinite(gap) else fallback


def band_request(needed: int, band_size: int, size: int) -> int:
    """Eigenpairs to ask of the next band when ``needed`` more are wanted.

    A band placed with ``next_shift`` brings about (1 + SHIFT_FRACTION) / 2 of its eigenpairs
    above the bound; the last band of a solve asks only for what covers the need.
    """
    cover = (1.0 + SHIFT_FRACTION) / 2.0
    wanted = math.ceil(needed / cover) + _EXTRA
    return int(max(2, min(band_size, wanted, size - 2)))


def next_shift(lower: float, count: int, gap: float) -> float:
    """Shift whose ``count`` nearest eigenvalues reach below ``lower``.

    With a mean gap g the band spans about count * g, half-width R = count * g / 2; the
    shift sits SHIFT_FRACTION * R above the bound.
    """
    return lower + SHIFT_FRACTION * 0.5 * count * gap
