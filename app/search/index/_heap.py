"""Give the heap memory a large transient pass freed back to the operating system.

glibc's allocator keeps what a thread freed in that thread's arena for reuse, so a pass
that allocates and frees many blocks of a few MB leaves the process tens of MB larger than
what it still holds: the neighbourhood pass (one block of vectors and products per inverted
list: +57 MB of its +84 MB at 10^5 models, measured in one process) and the start-up
rebuild (every row streamed from the database, the builders' buffers). ``malloc_trim(0)``
returns the free pages of every arena. Other C libraries (musl, macOS) have no such call
and need none here: there it does nothing.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import functools
from collections.abc import Callable

__all__ = ["trim_heap"]


@functools.cache
def _malloc_trim() -> Callable[[int], int] | None:
    name = ctypes.util.find_library("c")
    try:
        trim = ctypes.CDLL(name).malloc_trim
    except (OSError, AttributeError, TypeError):  # not glibc
        return None
    trim.argtypes, trim.restype = [ctypes.c_size_t], ctypes.c_int
    return trim


def trim_heap() -> bool:
    """Return freed heap pages to the operating system; whether the C library could."""
    trim = _malloc_trim()
    if trim is None:
        return False
    trim(0)
    return True
