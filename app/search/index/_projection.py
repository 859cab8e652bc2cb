"""A principal-component projection that shortens a compressed partition's codes
(``SHAPESEARCH_INDEX_PROJECTED_DIMS``, off by default).

An IVF partition's codes only choose the candidates; the exact re-rank reads the full
vectors (``app.search.full_vectors``). The codes therefore need not hold every dimension of
a descriptor, only enough of it to keep the true neighbours among the candidates. Projected
onto the 256 leading principal directions of the partition's training sample, the default
descriptor's 2832 padded dimensions scan ~5x faster and take ~9x fewer bytes (docs/benchmarks.md,
"Search at catalogue scale"). What it costs depends on the catalogue:

* the components are orthonormal rows, so the distance between two projections is never
  larger than the distance between the vectors: a true neighbour never looks farther than
  it is, and is missed only when more than the candidates' count of far vectors look
  nearer than it;
* real descriptors are nearly low-rank: on the 696 models of the seven tuning sources,
  with the directions fitted without the source queried, the 20 nearest projections held
  the true 10 nearest neighbours for six sources and 99.9 % of them for capod
  (bench/index_projection.py);
* noise spread evenly over every dimension is what no projection keeps: on
  bench/search_scale.py's synthetic catalogue (mixtures of real descriptors plus such
  noise) recall@10 after the re-rank falls from 1.0 to 0.85 at 10^5 and 0.37 at 10^6,
  each miss a near tie (the 10th answer 0.2 % and 1 % farther than the exact 10th).

The directions are found by a randomised SVD (Halko, Martinsson and Tropp 2011) with a fixed
seed, so one sample always gives one projection.
"""

from __future__ import annotations

import numpy as np

__all__ = ["Projection"]

_OVERSAMPLE = 64  # extra random directions: the leading ones come out accurate
_POWER_ITERATIONS = 2  # each sharpens the gap between leading and trailing directions
_FIT_ROWS = 8192  # a larger sample adds cost, not accuracy, to 256 directions


class Projection:
    """``vectors -> (vectors - mean_) @ components_.T``.

    Parameters
    ----------
    mean : (d,) float32
        The training sample's mean.
    components : (r, d) float32
        Orthonormal rows: the sample's ``r`` leading principal directions.
    """

    def __init__(self, mean: np.ndarray, components: np.ndarray) -> None:
        self.mean_ = np.ascontiguousarray(mean, dtype=np.float32)
        self.components_ = np.ascontiguousarray(components, dtype=np.float32)

    @property
    def dims(self) -> int:
        return int(self.components_.shape[0])

    @staticmethod
    def worthwhile(rows: int, width: int, dims: int) -> bool:
        """Whether ``dims`` directions (0: none) are worth fitting on a sample of ``rows``
        vectors ``width`` wide: both at least twice the directions, plus oversampling."""
        return dims > 0 and min(rows, width) >= 2 * dims + _OVERSAMPLE

    @classmethod
    def fit(cls, sample: np.ndarray, dims: int, seed: int = 0) -> Projection:
        """The ``dims`` leading principal directions of ``sample : (m, d) float``; needs
        ``dims + oversampling <= min(m, d)`` (callers project only large partitions)."""
        rows = np.asarray(sample[:_FIT_ROWS], dtype=np.float32)
        mean = rows.mean(axis=0)
        centred = rows - mean
        width = dims + _OVERSAMPLE
        if width > min(centred.shape):
            raise ValueError(f"{dims} directions need more than {min(centred.shape)} rows")
        gaussian = np.random.default_rng(seed).standard_normal((centred.shape[1], width))
        basis, _ = np.linalg.qr(centred @ gaussian.astype(np.float32))
        for _ in range(_POWER_ITERATIONS):
            basis, _ = np.linalg.qr(centred @ (centred.T @ basis))
        _, _, directions = np.linalg.svd(basis.T @ centred, full_matrices=False)
        return cls(mean, directions[:dims])

    def apply(self, vectors: np.ndarray) -> np.ndarray:
        """``vectors : (m, d) float32`` as ``(m, dims) float32`` coordinates."""
        return np.ascontiguousarray((vectors - self.mean_) @ self.components_.T)

    def nbytes(self) -> int:
        return int(self.mean_.nbytes + self.components_.nbytes)
