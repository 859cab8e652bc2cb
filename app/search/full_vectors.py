"""The full float32 vectors of a compressed index partition, for exact re-ranking.

A compressed (IVF-SQ) partition ranks by approximate distances; the few dozen candidates of
a query are then re-ranked exactly against their full vectors. Those live here, as rows of a
memory-mapped temporary file rather than in the process's own memory: 4 d bytes per model
(674 MB at 10^5 models of 1686 floats) would be four times the codes, while a query reads
only a few dozen rows. The kernel keeps the rows in its page cache while memory allows
and can always drop them, so the process's anonymous memory stays the codes' size. (The
layout vector databases use for "quantised vectors in memory, originals on disk".)

Before, the rows were read back from the database on every query: about 160 KB per query
over the wire for 23 candidates, the larger part of a similar request's cost.

The file is anonymous (unlinked at once, gone with the process) in the system's temporary
directory (``TMPDIR``). Its disk space is allocated before a row is written to it: a full
disk is an ``OSError`` at that point, not a SIGBUS in the middle of a write through the
mapping. It is sized for the rows expected and grows by half when they are exceeded; rows
freed by removals are reused, so churn does not grow it. Not thread-safe: the partition's
lock guards it.
"""

from __future__ import annotations

import mmap
import os
import tempfile
from collections.abc import Sequence

import numpy as np

__all__ = ["FullVectors"]

_MIN_ROWS = 1024  # smallest size of the file, in rows
_GROWTH = 1.5  # a full file grows to this many times its rows


class FullVectors:
    """Rows of ``dim`` float32 by integer id.

    Parameters
    ----------
    dim : int
        Floats per vector.
    expected : int
        Rows to make room for at once (more are allowed).
    """

    def __init__(self, dim: int, expected: int = 0) -> None:
        self.dim = dim
        self.expected = expected
        # Lives as long as this object (closed when it is collected): no context manager.
        self._file = tempfile.TemporaryFile(prefix="shapesearch-vectors-")  # noqa: SIM115
        self._rows: np.memmap | None = None
        self._row_of: dict[int, int] = {}
        self._free: list[int] = []
        self._high = 0  # rows handed out so far, freed ones included

    def __len__(self) -> int:
        return len(self._row_of)

    def __contains__(self, vector_id: int) -> bool:
        return vector_id in self._row_of

    @property
    def file_bytes(self) -> int:
        """Bytes of the file, allocated on disk and, while memory allows, held in the page
        cache (not the process's own memory)."""
        return 0 if self._rows is None else int(self._rows.nbytes)

    def put(self, ids: Sequence[int], vectors: np.ndarray) -> None:
        """Store ``vectors : (m, dim) float`` under ``ids`` (an id held is overwritten)."""
        # Room first: a failure to grow the file leaves nothing half done.
        new = len({int(i) for i in ids} - self._row_of.keys())
        self._ensure(self._high + max(0, new - len(self._free)))
        rows = [self._row_for(int(i)) for i in ids]
        assert self._rows is not None
        self._rows[rows] = np.asarray(vectors, dtype=np.float32)[:, : self.dim]

    def drop(self, ids: Sequence[int]) -> None:
        """Forget ``ids`` (unknown ones are ignored); their rows are reused."""
        for vector_id in ids:
            row = self._row_of.pop(int(vector_id), None)
            if row is not None:
                self._free.append(row)

    def get(self, ids: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
        """``(m, dim) float32`` copies of the rows of ``ids`` and a ``(m,) bool`` mask of
        the ids held (the rows of the others are zeros)."""
        row_of = self._row_of
        rows = [row_of.get(int(i), -1) for i in ids]
        held = np.array([row >= 0 for row in rows], dtype=bool)
        if self._rows is not None and len(rows) and held.all():  # the rule: one copy
            return np.ascontiguousarray(self._rows[rows]), held
        vectors = np.zeros((len(ids), self.dim), dtype=np.float32)
        if held.any() and self._rows is not None:
            vectors[held] = self._rows[[row for row in rows if row >= 0]]
        return vectors, held

    def evict(self) -> None:
        """Write the rows to disk and let the kernel drop them from memory, as it would
        under memory pressure: the next reads come from disk (benchmarks of a cold cache)."""
        if self._rows is None:
            return
        self._rows.flush()
        os.fsync(self._file.fileno())
        # numpy keeps the mapping private (no typed accessor): unmap this process's pages.
        self._rows._mmap.madvise(mmap.MADV_DONTNEED)  # type: ignore[attr-defined]
        if hasattr(os, "posix_fadvise"):  # Linux: out of the page cache too
            os.posix_fadvise(self._file.fileno(), 0, 0, os.POSIX_FADV_DONTNEED)

    def _row_for(self, vector_id: int) -> int:
        row = self._row_of.get(vector_id)
        if row is None:
            if self._free:
                row = self._free.pop()
            else:
                row, self._high = self._high, self._high + 1
            self._row_of[vector_id] = row
        return row

    def _ensure(self, rows: int) -> None:
        """Grow the file to hold at least ``rows`` rows, its disk space allocated."""
        capacity = 0 if self._rows is None else len(self._rows)
        if rows <= capacity:
            return
        capacity = max(rows, int(_GROWTH * capacity), self.expected, _MIN_ROWS)
        size = capacity * self.dim * 4
        if hasattr(os, "posix_fallocate"):
            # Allocated, not just a longer sparse file: a page written through the mapping
            # with no disk block to go to would kill the process with SIGBUS.
            os.posix_fallocate(self._file.fileno(), 0, size)
        else:  # macOS: a sparse file
            self._file.truncate(size)
        self._rows = np.memmap(self._file, dtype=np.float32, mode="r+", shape=(capacity, self.dim))
