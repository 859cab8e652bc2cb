"""Local signatures pooled over a fixed vocabulary: detail that global histograms drown.

The descriptor's histogram blocks pool every point's signature scale by scale, weighted by
area, so what tells a socket-head screw from a button-head one (a few per cent of the
surface) barely moves them. Here each point gets one local descriptor (its signature at
every scale together, optionally with how curved the surface is around it at two
neighbourhood sizes), and a model is encoded by how its points fall among the words of a
*fixed vocabulary*: a k-means codebook fitted once on tuning data and shipped with the
package (Bronstein et al. 2011, "Shape Google"). Two encodings:

- ``bof``: soft-assigned word frequencies, weighted by inverse document frequency
  (words that every part has, a flat face, count little; rare ones, teeth or a socket,
  count more), square-rooted and unit-normalised;
- ``vlad``: per word, the area-weighted sum of the points' residuals from the word's centre
  (Jegou et al. 2010), signed square root and per-word normalisation, so a small region
  whose signature differs from the common one still shows.

Every feature is invariant to rotation, translation, uniform scale and point order: the
signature is spectral, and the curvature measure is a ratio of local principal variances.
The vocabulary is data (``Vocabulary``), loaded from a versioned ``.npz`` whose digest
enters ``descriptor_version``.
"""

from __future__ import annotations

import hashlib
import io
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.cluster.vq import kmeans2
from scipy.spatial import cKDTree

__all__ = [
    "Vocabulary",
    "encode_bof",
    "encode_vlad",
    "local_descriptors",
    "surface_variation",
]


def surface_variation(points: np.ndarray, neighbours: tuple[int, ...]) -> np.ndarray:
    """How curved the surface is around each point, at several neighbourhood sizes.

    The surface variation of Pauly et al. (2002): the smallest principal variance of a
    point's ``k`` nearest neighbours over the sum of all three, 0 on a plane and 1/3 at
    most. A ratio, so free of scale; from variances, so free of rotation and of the sign
    of any normal.

    Parameters
    ----------
    points : (n, 3) float
    neighbours : tuple of int
        Neighbourhood sizes ``k``, one column each (capped at ``n - 1``).

    Returns
    -------
    variation : (n, len(neighbours)) float
    """
    largest = min(max(neighbours), len(points) - 1)
    _, index = cKDTree(points).query(points, k=largest + 1)
    columns = []
    for count in neighbours:
        local = points[index[:, : min(count, largest) + 1]]
        centred = local - local.mean(axis=1, keepdims=True)
        variances = np.linalg.eigvalsh(np.einsum("nki,nkj->nij", centred, centred))
        total = variances.sum(axis=1)
        smallest = np.maximum(variances[:, 0], 0.0)  # eigvalsh may give -0 round-off
        columns.append(np.where(total > 0, smallest / np.maximum(total, 1e-300), 0.0))
    return np.stack(columns, axis=1)


def local_descriptors(
    signature: np.ndarray, points: np.ndarray | None, neighbours: tuple[int, ...] = ()
) -> np.ndarray:
    """One local descriptor per point: its signature, then its surface variation.

    Parameters
    ----------
    signature : (n, s) float
        Per-point signature (``DescriptorSpec.signature``: log HKS, log WKS).
    points : (n, 3) float or None
        Needed when ``neighbours`` is not empty.
    neighbours : tuple of int
        Neighbourhood sizes of ``surface_variation``; empty for a purely intrinsic
        descriptor (unchanged by bending).

    Returns
    -------
    features : (n, s + len(neighbours)) float
    """
    if not neighbours:
        return np.asarray(signature, dtype=np.float64)
    if points is None:
        raise ValueError("surface variation needs the (n, 3) points")
    # sqrt spreads the variation's heavy mass near 0 (most points lie on flat faces).
    variation = np.sqrt(surface_variation(points, neighbours))
    return np.hstack([np.asarray(signature, dtype=np.float64), variation])


@dataclass(frozen=True)
class Vocabulary:
    """A fixed codebook of local descriptors and the statistics to encode against it.

    Attributes
    ----------
    centres : (k, d) float
        Word centres, in standardised feature units.
    mean, scale : (d,) float
        Standardisation: ``(feature - mean) / scale``.
    idf : (k,) float
        Inverse document frequency of each word on the fitting data.
    softness : float
        Soft-assignment width, in units of the median squared distance to the nearest word.
    """

    centres: np.ndarray
    mean: np.ndarray
    scale: np.ndarray
    idf: np.ndarray
    softness: float = 1.0

    @property
    def size(self) -> int:
        return int(self.centres.shape[0])

    @property
    def width(self) -> int:
        return int(self.centres.shape[1])

    @classmethod
    def fit(
        cls,
        features: list[np.ndarray],
        words: int,
        seed: int = 0,
        per_model: int = 400,
        softness: float = 1.0,
    ) -> Vocabulary:
        """k-means words on ``per_model`` points drawn from each model's features.

        Parameters
        ----------
        features : list of (n_i, d) float
            One array per model of the fitting data.
        words : int
        seed : int
            Seeds the point draw and k-means++: the same data give the same vocabulary.
        """
        rng = np.random.default_rng(seed)
        drawn = [
            rows[rng.choice(len(rows), min(per_model, len(rows)), replace=False)]
            for rows in features
        ]
        sample = np.vstack(drawn)
        mean = sample.mean(axis=0)
        scale = np.maximum(sample.std(axis=0), 1e-9)
        standard = (sample - mean) / scale
        centres, _ = kmeans2(standard, words, minit="++", seed=rng, iter=30)
        vocabulary = cls(centres, mean, scale, np.ones(words), softness)
        # Document frequency: the share of models in which a word holds >= 1 % of the mass.
        present = np.array([vocabulary.assign(rows).mean(axis=0) > 0.01 for rows in drawn])
        idf = np.log((1.0 + len(drawn)) / (1.0 + present.sum(axis=0))) + 1.0
        return cls(centres, mean, scale, idf, softness)

    def assign(self, features: np.ndarray) -> np.ndarray:
        """Soft assignment ``(n, k)`` of each feature row to the words (rows sum to 1)."""
        standard = (features - self.mean) / self.scale
        squared = (
            (standard**2).sum(axis=1)[:, None]
            + (self.centres**2).sum(axis=1)[None, :]
            - 2.0 * standard @ self.centres.T
        )
        squared = np.maximum(squared, 0.0)
        nearest = squared.min(axis=1, keepdims=True)
        # Width from the vocabulary's own scale: the mean squared spacing of its words.
        width = self.softness * self._spacing()
        weights = np.exp(-(squared - nearest) / width)
        return weights / weights.sum(axis=1, keepdims=True)

    def _spacing(self) -> float:
        gaps = cKDTree(self.centres).query(self.centres, k=2)[0][:, 1]
        return float(np.mean(gaps**2)) / 2.0

    def digest(self) -> str:
        """Ten hex digits of SHA-256 over the vocabulary's exact content."""
        buffer = io.BytesIO()
        np.savez(buffer, **self._arrays())  # type: ignore[arg-type]  # numpy's stubs: ** could fill allow_pickle
        return hashlib.sha256(buffer.getvalue()).hexdigest()[:10]

    def _arrays(self) -> dict[str, np.ndarray]:
        return {
            "centres": self.centres, "mean": self.mean, "scale": self.scale,
            "idf": self.idf, "softness": np.array(self.softness),
        }

    def save(self, path: str | Path) -> None:
        np.savez(path, **self._arrays())  # type: ignore[arg-type]  # numpy's stubs: ** could fill allow_pickle

    @classmethod
    def load(cls, path: str | Path) -> Vocabulary:
        with np.load(path) as data:
            return cls(
                centres=data["centres"], mean=data["mean"], scale=data["scale"],
                idf=data["idf"], softness=float(data["softness"]),
            )


def encode_bof(features: np.ndarray, areas: np.ndarray, vocabulary: Vocabulary) -> np.ndarray:
    """Area-weighted, idf-weighted word frequencies, square-rooted, unit norm ``(k,)``.

    Parameters
    ----------
    features : (n, d) float
    areas : (n,) float
        Non-negative; the area each point stands for.
    vocabulary : Vocabulary
    """
    frequencies = areas @ vocabulary.assign(features)
    frequencies = frequencies / max(frequencies.sum(), 1e-300)
    weighted = np.sqrt(frequencies * vocabulary.idf)
    return weighted / max(np.linalg.norm(weighted), 1e-300)


def encode_vlad(features: np.ndarray, areas: np.ndarray, vocabulary: Vocabulary) -> np.ndarray:
    """VLAD: per word, the area-weighted residual sum, ``(k * d,)`` of unit norm.

    Each word's residual is signed-square-rooted and scaled to unit norm (intra
    normalisation, Arandjelovic & Zisserman 2013), so a word that few points visit counts
    as much as a common one.
    """
    standard = (features - vocabulary.mean) / vocabulary.scale
    weights = vocabulary.assign(features) * (areas / max(areas.sum(), 1e-300))[:, None]
    # sum_x w_xk (f_x - c_k) = W^T F - (sum_x w_xk) c_k
    residuals = weights.T @ standard - weights.sum(axis=0)[:, None] * vocabulary.centres
    residuals = np.sign(residuals) * np.sqrt(np.abs(residuals))
    norms = np.linalg.norm(residuals, axis=1, keepdims=True)
    residuals = np.where(norms > 0, residuals / np.maximum(norms, 1e-300), 0.0)
    flat = residuals.ravel()
    return flat / max(np.linalg.norm(flat), 1e-300)
