"""Hub-discount neighbourhoods saved to disk, and restored when an API process starts.

A whole pass over a partition's neighbourhoods (``_neighbours.keep_neighbourhoods``) takes
about 17 minutes of a core at 10^6 models, and until it has kept a query's candidates the
query computes their own (~170 ms instead of 0.06 ms). So that an API process does not
pay that after each start, the index saves what a pass kept, a file per partition
(``save``), and a process that starts restores it (``restore``) instead of computing it
again, forgetting what the changes since have moved, as a running process does for each
change (``_kept``):

* the file says the change-feed revision it is of, and the feed's events after it name
  the models added, replaced or deleted since (the ``touched``);
* a touched model's own neighbourhood is forgotten, and so is every one a touched model
  is among the ``k + 1`` members of (the file keeps them: a deleted model's vector, with
  which a running process finds them, is gone);
* so is every one that a touched model held now enters (``_kept.entered``: a search of its
  ``FORGET_NEAREST`` nearest, as a change does).

A file also holds a few of the partition's vectors, which must be bit for bit those the
partition holds, and the feed's event at its revision, which must be the database's: a file
of another database, or of this one restored from an older backup, is not used. Nor is one
whose events were pruned since (``app.db.retention``), one of another ``k``, or one the
partition changed too much since for it to keep half (``worth_restoring``).

A file is written whole and renamed into place, so a reader never sees part of one, and
processes that share the directory share the files (the last one saved wins; any is right
for its revision). They share the work too: one process at a time computes a partition's
(``computing``: a lock beside its file) and saves what it kept, and the others restore that
instead of computing the same (two API processes on a host of two cores would otherwise
spend a core each on the same pass).

Files no process reads any more are removed (``tidy``): those of a partition the database
no longer holds (a retired descriptor version, a tenant's last model deleted) or of another
``k``, once a day has passed since they were last written, and what a process killed while
saving left (at 10^6 models each is 77 MB).

The IVF lists of a restarted process come from a new k-means training, so the
neighbourhoods an approximate partition restores are those the saving process's lists
found: as approximate as its own pass's, not bit for bit the same.
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import json
import logging
import os
import tempfile
import time
from collections.abc import Collection, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import BinaryIO

import numpy as np

from app.search.index._kept import PassTable, entered, member_keys
from app.search.index._partition import Partition
from app.search.index._view_ids import PartitionKey

__all__ = [
    "SavedNeighbourhoods",
    "computing",
    "file_for",
    "load",
    "restore",
    "save",
    "tidy",
    "worth_restoring",
]

log = logging.getLogger("shapesearch.index")

FORMAT = 1  # the files' layout; another is not read
PROBES = 8  # vectors a file holds to recognise its partition
_ENTER_CHUNK = 256  # touched models checked per read lock (a change waits for one chunk)
# A file no partition of this process reads is removed once it is this old (seconds): a
# day covers a rolling deploy whose older processes read another ``k`` meanwhile, and a
# save in flight (0.1 s at 10^6 models) is never that old.
STALE_AFTER = 24 * 3600.0


@dataclass(frozen=True)
class SavedNeighbourhoods:
    """A partition's kept neighbourhoods as saved.

    key : (tenant, descriptor_version)
        The partition.
    k : int
        The neighbourhoods' size.
    revision : int
        The change-feed revision the partition was at: every event up to it, none after.
    stamp : str
        The event at ``revision`` as the database holds it (model, kind, time; empty at
        revision 0): a database whose feed went another way since (restored from a backup
        older than the file, then changed) has another there.
    table : PassTable
        The neighbourhoods, every row held.
    probe_ids : (p,) int64
        A few of the partition's ids, ``probe_vectors : (p, d) float32`` their vectors.
    """

    key: PartitionKey
    k: int
    revision: int
    stamp: str
    table: PassTable
    probe_ids: np.ndarray
    probe_vectors: np.ndarray

    @classmethod
    def of(
        cls, partition: Partition, key: PartitionKey, k: int, revision: int, stamp: str,
        table: PassTable,
    ) -> SavedNeighbourhoods:
        """From ``partition``'s kept ``table`` at ``revision`` (call with no change
        running: the index's sync lock)."""
        picked = np.linspace(0, len(table.ids) - 1, min(PROBES, len(table.ids))).astype(int)
        probe_ids = table.ids[np.unique(picked)]
        with partition.lock.reading():
            vectors, _ = partition.exact_vectors(probe_ids.tolist())
        return cls(key, k, revision, stamp, table, probe_ids, vectors)


def file_for(directory: Path, key: PartitionKey, k: int) -> Path:
    """Where the neighbourhoods of partition ``key`` of size ``k`` are saved."""
    digest = hashlib.sha256("\0".join(key).encode()).hexdigest()[:32]
    return directory / f"neighbourhoods-{digest}-k{k}.npz"


@contextlib.contextmanager
def computing(path: Path) -> Iterator[bool]:
    """Whether this process may compute the neighbourhoods saved at ``path`` now: True
    while it holds the lock beside the file (``flock``, let go when the process ends
    however it ends); False when another process holds it, which then saves what it
    computed for this one to restore. A lock that cannot be made (the directory is not
    writable) is said in the log, and this process computes."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        lock = open(path.with_suffix(".lock"), "a+b")  # noqa: SIM115 (closed below)
    except OSError as error:
        log.warning("no lock for the hub-discount neighbourhoods at %s: %s", path, error)
        yield True
        return
    with lock:
        try:
            fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            yield False
            return
        try:
            yield True
        finally:
            fcntl.flock(lock, fcntl.LOCK_UN)


def tidy(
    directory: Path, read: Collection[Path], *, stale_after: float = STALE_AFTER,
    now: float | None = None,
) -> list[Path]:
    """Remove from ``directory`` the saved neighbourhoods that no partition reads, the
    ``read`` paths (``file_for`` each partition held, at this process's ``k``), written
    more than ``stale_after`` seconds before ``now``: files and their locks, and the parts a
    save left when its process was killed. A lock another process holds stays, and so does
    what is not such a file. The paths removed; a failure is said in the log."""
    now = time.time() if now is None else now
    names = {path.name for path in read}
    removed: list[Path] = []
    for path in _saved_files(directory):
        data = path.with_suffix(".npz").name if path.suffix == ".lock" else path.name
        if data in names:
            continue
        try:
            if now - path.stat().st_mtime <= stale_after:
                continue
            if path.suffix == ".lock":
                if not _unlink_unheld(path):
                    continue
            else:
                path.unlink()
        except FileNotFoundError:  # another process of the directory removed it first
            continue
        except OSError as error:
            log.warning("saved neighbourhoods %s not removed: %s", path, error)
            continue
        removed.append(path)
    return removed


def _saved_files(directory: Path) -> list[Path]:
    """What ``save`` and ``computing`` write in ``directory``: files, locks and the
    temporary files of saves."""
    try:
        return [path for path in directory.iterdir() if path.name.startswith(
            ("neighbourhoods-", ".neighbourhoods-")) and path.is_file()]
    except OSError:  # no such directory (nothing to remove), or not one (said at save)
        return []


def _unlink_unheld(lock_path: Path) -> bool:
    """Remove the lock file at ``lock_path`` unless a process holds it; whether removed."""
    with open(lock_path, "a+b") as lock:
        try:
            fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            return False
        lock_path.unlink()  # while held: no process takes it in between
        return True


def save(path: Path, saved: SavedNeighbourhoods) -> None:
    """Write ``saved`` to ``path`` whole: a file beside it, then renamed over it."""
    path.parent.mkdir(parents=True, exist_ok=True)
    header = {"format": FORMAT, "key": list(saved.key), "k": saved.k,
              "revision": saved.revision, "stamp": saved.stamp}
    with _replacing(path) as stream:
        table = saved.table
        np.savez(stream, header=np.array(json.dumps(header)), ids=table.ids,
                 values=table.values, members=table.members, probe_ids=saved.probe_ids,
                 probe_vectors=saved.probe_vectors)


@contextlib.contextmanager
def _replacing(path: Path) -> Iterator[BinaryIO]:
    handle, temporary = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    try:
        with os.fdopen(handle, "wb") as stream:
            yield stream
            stream.flush()
            os.fsync(stream.fileno())
        os.replace(temporary, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(temporary)
        raise


def load(path: Path, key: PartitionKey, k: int) -> SavedNeighbourhoods | None:
    """The neighbourhoods saved at ``path`` for partition ``key`` and ``k``; None when
    there are none, or the file is not such a file (said in the log)."""
    if not path.is_file():
        return None
    try:
        with np.load(path, allow_pickle=False) as arrays:
            header = json.loads(str(arrays["header"]))
            ids, values = arrays["ids"], arrays["values"]
            members, probe_ids = arrays["members"], arrays["probe_ids"]
            probe_vectors = arrays["probe_vectors"]
        n = len(ids)
        layout = (header.get("format") == FORMAT and tuple(header.get("key", ())) == key
                  and header.get("k") == k and isinstance(header.get("revision"), int)
                  and isinstance(header.get("stamp"), str)
                  and ids.dtype == np.int64 and ids.shape == (n,)
                  and values.dtype == np.float64 and values.shape == (n, 3)
                  and members.dtype == np.uint32 and members.shape == (n, k + 1)
                  and probe_ids.dtype == np.int64 and probe_ids.ndim == 1
                  and probe_vectors.dtype == np.float32 and probe_vectors.ndim == 2
                  and len(probe_vectors) == len(probe_ids) and bool(np.isin(probe_ids, ids).all()))
    except Exception as error:  # whatever a damaged file raises (zip, npy, JSON): not used
        log.warning("saved neighbourhoods %s unreadable, not used: %s", path, error)
        return None
    if not layout:
        log.warning("saved neighbourhoods %s are not of partition %s with k %d in format %d, "
                    "not used", path, key, k, FORMAT)
        return None
    table = PassTable.of(ids, values, members)
    return SavedNeighbourhoods(key, k, int(header["revision"]), header["stamp"], table,
                               probe_ids, probe_vectors)


def worth_restoring(k: int, touched: int, held: int) -> bool:
    """Whether neighbourhoods of ``k`` saved before ``touched`` models of a partition of
    ``held`` changed can still keep half: each touched model is among about ``k + 1``
    neighbourhoods, and has its own (or enters as many). Past that, a pass from nothing is
    not much longer, and checking every touched model costs a search each."""
    return (k + 2) * touched <= held / 2


def restore(
    partition: Partition, saved: SavedNeighbourhoods, touched: np.ndarray, version: int
) -> int | None:
    """Keep ``saved`` in ``partition`` (``KeptNeighbourhoods.restore``) but what the models
    ``touched : (t,) int64`` since its revision moved; the count kept. None, keeping
    nothing, when it is not the partition's (its probes differ, or an untouched model of it
    is gone), when the partition changed since ``version`` (``kept.version``, read with the
    partition at the revision the touched end at), when not ``worth_restoring``, or when
    it would keep no more than the partition's passes keep already."""
    table = saved.table
    touched = np.unique(np.asarray(touched, dtype=np.int64))
    with partition.lock.reading():
        if partition.kept.version != version:
            return None
        held_ids = partition.ids()
        # Of the models touched since, those of this partition: then or now.
        touched = touched[np.isin(touched, table.ids) | np.isin(touched, held_ids)]
        if not worth_restoring(saved.k, len(touched), len(held_ids)):
            return None
        if not _recognised(partition, saved, touched, held_ids):
            return None
    drop = np.isin(table.ids, touched) | np.isin(table.members, member_keys(touched)).any(axis=1)
    kept = table.without(drop)
    # A touched model held now may have entered neighbourhoods that have no trace of it.
    present = touched[np.isin(touched, held_ids)]
    moved: list[int] = []
    for start in range(0, len(present), _ENTER_CHUNK):
        chunk = present[start:start + _ENTER_CHUNK].tolist()
        with partition.lock.reading():
            if partition.kept.version != version:
                return None
            vectors, _ = partition.exact_vectors(chunk)
            moved.extend(entered(partition, vectors, kept.lookup))
    kept = kept.without(np.isin(kept.ids, np.asarray(moved, dtype=np.int64)))
    with partition.lock.reading():
        if partition.kept.version != version or len(kept.ids) <= partition.kept.tabled:
            return None
        partition.kept.use(saved.k)
        partition.kept.restore(kept, len(held_ids))
    return len(kept.ids)


def _recognised(
    partition: Partition, saved: SavedNeighbourhoods, touched: np.ndarray, held_ids: np.ndarray
) -> bool:
    """Whether ``partition`` (holding ``held_ids``) holds every saved model not touched
    since, and the untouched probes' vectors bit for bit (call with its read lock held)."""
    untouched = saved.table.ids[~np.isin(saved.table.ids, touched)]
    if not np.isin(untouched, held_ids).all():
        return False
    probes = ~np.isin(saved.probe_ids, touched)
    vectors, held = partition.exact_vectors(saved.probe_ids[probes].tolist())
    expected = saved.probe_vectors[probes]
    return bool(held.all()) and vectors.shape == expected.shape and bool(
        np.array_equal(vectors, expected))
