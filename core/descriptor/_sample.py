"""What the descriptor's blocks measure: one model's signature, areas, spectrum and points.

Several blocks measure the same derived data (the surface normals, the part with its long
runs of one cross-section shortened, the areas and spreads of the evened surface); a
``Sample`` computes each of them once, on first use, so a block only asks for what it needs
and a block that is off costs nothing.
"""

from __future__ import annotations

from functools import cached_property

import numpy as np

from core.extrinsic import evened_areas, evened_spreads, shortened_runs, surface_normals

__all__ = ["Sample"]


class Sample:
    """One model as the blocks see it.

    Parameters
    ----------
    signature : (n, s) float
        Per-point signature: log HKS at each of ``hks_count`` times, then log WKS at each
        energy (``DescriptorSpec.signature``).
    areas : (n,) float
        The area each point stands for.
    eigenvalues : (k,) float
        Unit-area eigenvalues.
    points : (n, 3) float, optional
        The points the signature was computed on (any position and scale); needed by the
        blocks measured on them.
    hks_count : int
        How many of the signature's columns are log HKS.
    normal_neighbours : int
        Neighbours of the local PCA that estimates the normals (``surface_normals``).
    runs_longest : float, optional
        The extrinsic blocks measure the part with each run of one cross-section along its
        first axis longer than this many radii shortened to it (``shortened_runs``); None:
        the part as it is.
    """

    def __init__(
        self,
        signature: np.ndarray,
        areas: np.ndarray,
        eigenvalues: np.ndarray,
        points: np.ndarray | None = None,
        *,
        hks_count: int,
        normal_neighbours: int = 12,
        runs_longest: float | None = None,
    ) -> None:
        self.signature = signature
        self.areas = areas
        self.eigenvalues = eigenvalues
        self._points = points
        self.hks_count = hks_count
        self.normal_neighbours = normal_neighbours
        self.runs_longest = runs_longest

    @property
    def log_hks(self) -> np.ndarray:
        """The signature's log HKS columns, ``(n, hks_count) float``."""
        return self.signature[:, : self.hks_count]

    @property
    def log_wks(self) -> np.ndarray:
        """The signature's log WKS columns, ``(n, s - hks_count) float``."""
        return self.signature[:, self.hks_count :]

    @property
    def points(self) -> np.ndarray:
        """The points, ``(n, 3) float``.

        Raises
        ------
        ValueError
            No points were given, or not one per signature row.
        """
        if self._points is None or self._points.shape != (self.signature.shape[0], 3):
            raise ValueError("the extrinsic blocks need the (n, 3) points of the signature")
        return self._points

    @cached_property
    def normals(self) -> np.ndarray:
        """Unoriented unit normals of the sample's points, ``(n, 3) float``, in the frame of
        ``body_points``: estimated on the sample itself (a shortened run faces where it
        faced, and its denser points would not show that)."""
        normals = surface_normals(self.points, self.normal_neighbours)
        axes = self._body[2]
        return normals if axes is None else normals @ axes

    @cached_property
    def _body(self) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """``shortened_runs``' coordinates, areas and axes, or the sample as it is and None."""
        if self.runs_longest is None:
            return self.points, self.areas, None
        return shortened_runs(self.points, self.areas, self.runs_longest)

    @property
    def body_points(self) -> np.ndarray:
        """What the extrinsic blocks measure, ``(n, 3) float``: the points with their long
        runs of one cross-section shortened (in the principal frame), or as they are."""
        return self._body[0]

    @property
    def body_areas(self) -> np.ndarray:
        """The areas of ``body_points``, ``(n,) float`` (a shortened run's shrink with it)."""
        return self._body[1]

    @cached_property
    def evened_areas(self) -> np.ndarray:
        """The area each point of ``body_points`` has on the evened surface, ``(n,) float``
        (``core.extrinsic.evened_areas``): a long part's body does not outweigh its ends."""
        return evened_areas(self.body_points, self.body_areas, self.normals)

    @cached_property
    def evened_points(self) -> np.ndarray:
        """``body_points`` with their principal spreads evened, ``(n, 3) float``
        (``core.extrinsic.evened_spreads``, weighed by ``evened_areas``): distances measured
        on them describe the layout apart from the proportions."""
        return evened_spreads(self.body_points, self.evened_areas)
