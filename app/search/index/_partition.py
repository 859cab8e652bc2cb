"""One FAISS partition: flat while small, IVF with scalar-quantised codes when compressed
(the full vectors then live in a memory-mapped file, ``app.search.full_vectors``; on request
the codes hold the vectors' leading principal components, ``_projection``).

The codes leave out every dimension that is constant over the training sample. Such a
dimension adds one and the same amount to every estimated distance, so it cannot change
which candidates a query gets: FAISS's scalar quantiser trains a zero range for it and
decodes every vector's value there to the same constant, whatever was added later (the
estimates a search returns leave that amount out: zero for a query that is constant there
too, and otherwise smaller estimates, which only make the scan-mode search's bound more
cautious). Real descriptors have many: histogram bins at the ends of their ranges that no
shape reaches (100 of the default's 2961 dimensions on all 695 models of the seven tuning
sources), so the codes shrink by their bytes and the scan by their work, with the same
candidates."""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence

import faiss
import numpy as np

from app.search.full_vectors import FullVectors
from app.search.index._kept import KeptNeighbourhoods
from app.search.index._lock import ReadWriteLock
from app.search.index._projection import Projection

__all__ = ["TRAIN_PER_LIST", "Partition", "list_ids"]

TRAIN_PER_LIST = 16  # k-means training vectors per inverted list
_TRAIN_ITERATIONS = 8
_QUANTIZERS = {8: faiss.ScalarQuantizer.QT_8bit, 4: faiss.ScalarQuantizer.QT_4bit}
# Exact re-rank candidates per wanted result, relative to 8-bit codes: 4-bit distance
# estimates err more, so the true top 10 of 2787-dim descriptors needs about 40 candidates
# where 8-bit codes need 20 (a one-off comparison at 2x10^5: recall@10 0.988 with 20, 0.998
# with 40; at 10^6 with 40, 0.994: bench/search_scale.py --phases index).
_RERANK_SCALE = {8: 1, 4: 2}
_SERIALS = itertools.count(1)  # each partition object its own, never reused


class Partition:
    """The vectors of one (tenant, descriptor_version), flat or IVF with scalar-quantised
    codes of ``bits`` 8 or 4; with ``projected_dims`` > 0, an IVF partition's codes hold
    that many principal components of the vectors instead of every dimension (when the
    vectors and the training sample are wide and large enough: ``Projection.worthwhile``)."""

    def __init__(self, dim: int, nprobe: int, projected_dims: int = 0) -> None:
        self.dim = dim
        # Zero-padded to a multiple of 16: FAISS's SIMD scalar-quantiser kernels need it
        # (1534 dims scan ~20x slower than 1536); L2 distances are unchanged.
        self.padded = -(-dim // 16) * 16
        self.nprobe = nprobe
        self.projected_dims = projected_dims
        self.index: faiss.Index = faiss.IndexIDMap2(faiss.IndexFlatL2(self.padded))
        self.bits = 32  # float32 while flat
        self.full: FullVectors | None = None  # the full vectors, once compressed
        self.projection: Projection | None = None  # what the codes hold, when not all
        # The dimensions the codes hold when some are constant over the training sample.
        self.varying: np.ndarray | None = None
        self.lock = ReadWriteLock()
        # The hub discount's neighbourhoods, kept while a change does not move them.
        self.kept = KeptNeighbourhoods()
        # (serial, version) names what the partition holds: version counts its changes, so
        # what was computed from it (scan mode's entry neighbours) is known to be current.
        self.serial = next(_SERIALS)
        self.version = 0

    @property
    def kind(self) -> str:
        if self.bits == 32:
            return "flat"
        projected = "" if self.projection is None else f"pca{self.projection.dims}-"
        return f"{projected}ivf-sq{self.bits}"

    @property
    def size(self) -> int:
        """How many vectors it holds."""
        return int(self.index.ntotal)

    @property
    def approximate(self) -> bool:
        return self.bits != 32

    @property
    def rerank_scale(self) -> int:
        """Re-rank candidates per wanted result, relative to 8-bit codes (0: exact)."""
        return _RERANK_SCALE.get(self.bits, 0)

    def compress(self, sample: np.ndarray, expected: int, bits: int = 8) -> None:
        """Switch to IVF with ``bits``-bit codes (8 or 4) trained on ``sample : (m, d)
        float32``; moves what is held."""
        nlist = int(np.clip(math.sqrt(expected), 16, 4096))
        nlist = min(nlist, max(1, len(sample) // 4))
        padded = self.pad(sample)
        if Projection.worthwhile(len(sample), self.padded, self.projected_dims):
            self.projection = Projection.fit(padded, self.projected_dims)
        else:
            self.varying = _varying_dimensions(padded)
        coded = self.coded_dims
        quantizer = faiss.IndexFlatL2(coded)
        ivf = faiss.IndexIVFScalarQuantizer(
            quantizer, coded, nlist, _QUANTIZERS[bits], faiss.METRIC_L2
        )
        ivf.cp.niter = _TRAIN_ITERATIONS
        ivf.cp.min_points_per_centroid = 1  # a small sample is enough for coarse lists
        ivf.train(self.codable(sample[: TRAIN_PER_LIST * nlist]))
        ivf.set_direct_map_type(faiss.DirectMap.Hashtable)  # remove_ids without a scan
        ivf.nprobe = self.nprobe
        held = self.index
        full = FullVectors(self.dim, expected)
        if held.ntotal:
            ids = faiss.vector_to_array(held.id_map).astype(np.int64)
            vectors = held.index.reconstruct_n(0, held.ntotal)  # padded already
            full.put(ids.tolist(), vectors)
            ivf.add_with_ids(self._coded(vectors), ids)
        self.index, self.bits, self.full = ivf, bits, full

    def nbytes(self) -> int:
        n = int(self.index.ntotal)
        if not self.approximate:
            return n * (4 * self.padded + 16)  # float32 rows, the id map both ways
        # Codes and an id per vector, ~24 bytes of direct map, float32 centroids.
        centroids = self.index.nlist * self.index.d * 4
        projection = 0 if self.projection is None else self.projection.nbytes()
        return n * (self.index.code_size + 8 + 24) + centroids + projection

    def pad(self, vectors: np.ndarray) -> np.ndarray:
        """``vectors : (m, dim) float`` as ``(m, padded) float32``."""
        padded = np.zeros((len(vectors), self.padded), dtype=np.float32)
        padded[:, : vectors.shape[1]] = vectors
        return padded

    @property
    def coded_dims(self) -> int:
        """Dimensions of what the index holds: every (padded) one, the principal components,
        or the varying ones padded to a multiple of 16."""
        if self.projection is not None:
            return self.projection.dims
        if self.varying is not None:
            return -(-len(self.varying) // 16) * 16
        return self.padded

    def codable(self, vectors: np.ndarray) -> np.ndarray:
        """``vectors : (m, dim) float`` as the index takes them: padded, then projected
        when the codes hold principal components, or cut to the varying dimensions."""
        return self._coded(self.pad(vectors))

    def _coded(self, padded: np.ndarray) -> np.ndarray:
        if self.projection is not None:
            return self.projection.apply(padded)
        if self.varying is None:
            return padded
        coded = np.zeros((len(padded), self.coded_dims), dtype=np.float32)
        coded[:, : len(self.varying)] = padded[:, self.varying]
        return coded

    def add(self, ids: np.ndarray, vectors: np.ndarray) -> None:
        self.version += 1
        self.kept.changed(self, ids, vectors)
        if self.full is not None:  # first: when its disk is full, nothing is added
            self.full.put(ids.tolist(), vectors)
        self.index.add_with_ids(self.codable(vectors), ids)

    def remove(self, ids: np.ndarray) -> None:
        self.version += 1
        self.kept.changed(self, ids)  # first: it reads the leaving vectors
        # An array selector: the IVF direct map (a hashtable) then removes without a scan.
        self.index.remove_ids(faiss.IDSelectorArray(len(ids), faiss.swig_ptr(ids)))
        if self.full is not None:
            self.full.drop(ids.tolist())

    def ids(self) -> np.ndarray:
        """``(n,) int64``: every id held, in no particular order."""
        if not self.approximate:
            return faiss.vector_to_array(self.index.id_map).astype(np.int64)
        invlists = faiss.extract_index_ivf(self.index).invlists
        return np.concatenate([np.zeros(0, dtype=np.int64)] + [
            list_ids(invlists, number) for number in range(invlists.nlist)])

    def exact_vectors(self, ids: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
        """``(m, dim) float32`` vectors of ``ids`` as added, and a ``(m,) bool`` mask of
        the ids held."""
        if self.full is not None:
            return self.full.get(ids)
        if len(ids):
            try:  # every one held (the rule): one call instead of one per id
                keys = np.asarray(ids, dtype=np.int64)
                vectors = self.index.reconstruct_batch(keys)[:, : self.dim]
                return np.ascontiguousarray(vectors), np.ones(len(ids), dtype=bool)
            except RuntimeError:  # some are not held: one at a time
                pass
        vectors = np.zeros((len(ids), self.dim), dtype=np.float32)
        held = np.zeros(len(ids), dtype=bool)
        for row, vector_id in enumerate(ids):
            try:
                vectors[row] = self.index.reconstruct(int(vector_id))[: self.dim]
                held[row] = True
            except RuntimeError:  # not held
                pass
        return vectors, held

    def search(
        self, query: np.ndarray, k: int, allowed: np.ndarray | None
    ) -> tuple[np.ndarray, np.ndarray]:
        params = None
        if allowed is not None:
            selector = faiss.IDSelectorBatch(allowed)
            if self.approximate:
                # Every list may hold an allowed id: probe them all, the selector keeps
                # the scan to the allowed codes' distances.
                params = faiss.SearchParametersIVF(sel=selector, nprobe=self.index.nlist)
            else:
                params = faiss.SearchParameters(sel=selector)
        coded = self.codable(query)
        squared, ids = self.index.search(coded, k, params=params)
        if params is None and self.approximate and (ids[:, -1] < 0).any():
            # The nprobe nearest lists held fewer than k vectors: a caller widening its
            # search (filters, scan mode) would take that for the end of the partition.
            # Probe every list instead, so k results come back whenever k exist.
            every = faiss.SearchParametersIVF(nprobe=self.index.nlist)
            squared, ids = self.index.search(coded, k, params=every)
        return squared, ids


def list_ids(invlists: faiss.InvertedLists, number: int) -> np.ndarray:
    """The ids held in inverted list ``number``."""
    size = invlists.list_size(number)
    if size == 0:
        return np.zeros(0, dtype=np.int64)
    return faiss.rev_swig_ptr(invlists.get_ids(number), size).astype(np.int64)


def _varying_dimensions(sample: np.ndarray) -> np.ndarray | None:
    """The columns of ``sample : (m, d)`` that are not constant, or None when leaving out
    the rest would not shorten the codes (fewer than 16: the codes are padded to 16)."""
    varying = np.flatnonzero(sample.max(axis=0) > sample.min(axis=0))
    if len(varying) == 0 or -(-len(varying) // 16) * 16 >= sample.shape[1]:
        return None  # (nothing varies: codes of every dimension, as for a tiny sample)
    return varying
