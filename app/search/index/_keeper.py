"""Keeping every partition's hub-discount neighbourhoods: computed by passes
(``_neighbours.keep_neighbourhoods``), saved to a cache directory and restored from it
(``_saved``), so that a process that starts finds those its predecessor kept.

A pass over a partition is computed by one process of a cache directory at a time and saved
at its end: a process that finds another computing leaves the partition for now (the index
still wants its neighbourhoods) and restores what the other saves.
"""

from __future__ import annotations

import logging
from pathlib import Path

from sqlalchemy.orm import Session, sessionmaker

from app.db.feed import event_stamp, models_touched
from app.search.index._heap import trim_heap
from app.search.index._held import Held
from app.search.index._neighbours import keep_neighbourhoods
from app.search.index._partition import Partition
from app.search.index._saved import (
    SavedNeighbourhoods,
    computing,
    file_for,
    load,
    restore,
    save,
    tidy,
)
from app.search.index._view_ids import PartitionKey, holds_views

__all__ = ["NeighbourhoodKeeper"]

log = logging.getLogger("shapesearch.index")


class NeighbourhoodKeeper:
    """The hub-discount neighbourhoods of ``held``'s model partitions, kept with ``k``
    neighbours (given on each call: the index's ``hub_neighbours``; below 1, the discount is
    off and nothing is kept).

    Parameters
    ----------
    held : Held
        The partitions.
    sessions : sessionmaker or None
        The database, whose change feed tells which models changed since a file was saved;
        None: nothing is saved or restored.
    cache_dir : Path or None
        Where the neighbourhoods are saved and restored from; None: neither.
    every_partition : bool
        Whether ``held`` holds every partition of the database, so that the files in
        ``cache_dir`` that none of them reads can go.
    """

    def __init__(
        self,
        held: Held,
        sessions: sessionmaker[Session] | None,
        cache_dir: Path | None,
        *,
        every_partition: bool,
    ) -> None:
        self.held = held
        self.sessions = sessions
        self.cache_dir = cache_dir
        self.every_partition = every_partition
        # The saved neighbourhoods' file each partition last tried to restore, by its stat.
        self._restores_tried: dict[PartitionKey, tuple[int, int, int]] = {}
        self._waiting: set[PartitionKey] = set()  # for another process's pass (said once)

    def _models(self) -> list[tuple[PartitionKey, Partition]]:
        """The FAISS partitions of models (a Milvus partition keeps only what queries
        computed: a pass would read every vector back from Milvus)."""
        return [(key, partition) for key, partition in list(self.held.partitions.items())
                if not holds_views(key) and isinstance(partition, Partition)]

    def keep(self, k: int) -> int:
        """Compute every model's neighbourhood now, partition by partition; the count kept.
        With a ``cache_dir``, a partition first restores those saved there (a restore that
        keeps most counts as its pass)."""
        if k < 1:
            return 0
        kept = 0
        for key, partition in self._models():
            if self.cache_dir is None:
                kept += keep_neighbourhoods(partition, k)
                continue
            self._restore(key, partition, k)
            if not partition.kept.passed:
                self._compute_or_wait(key, partition, k)
            kept += partition.kept.tabled
        trim_heap()  # the pass's blocks, freed: most of what it grew the process by
        return kept

    def _compute_or_wait(self, key: PartitionKey, partition: Partition, k: int) -> None:
        """Compute partition ``key``'s pass and save it, unless another process of the
        cache directory is computing it (then this one restores what that one saves)."""
        assert self.cache_dir is not None
        with computing(file_for(self.cache_dir, key, k)) as ours:
            if ours:
                self._waiting.discard(key)
                # The last holder may have saved its pass since the caller's look.
                self._restore(key, partition, k)
                if not partition.kept.passed:
                    keep_neighbourhoods(partition, k)
                    self._save(key, partition, k)
            elif key not in self._waiting:
                log.info("another process computes the hub-discount neighbourhoods of %s: "
                         "restoring what it saves", key)
                self._waiting.add(key)

    def save(self, k: int) -> int:
        """Save each partition's kept neighbourhoods that changed since it last saved them
        (``_saved``: a file per partition, written whole), and remove the files there that
        no partition reads (``_saved.tidy``); the count of files written. A directory that
        cannot be written is said in the log, and nothing else happens."""
        if self.cache_dir is None or k < 1:
            return 0
        partitions = self._models()
        written = sum(self._save(key, partition, k) for key, partition in partitions)
        if self.every_partition:  # it knows every partition: what none reads can go
            read = [file_for(self.cache_dir, key, k)
                    for key, partition in partitions if partition.size > 0]
            removed = tidy(self.cache_dir, read)
            if removed:
                log.info("removed %d saved hub-discount neighbourhood files no partition "
                         "reads from %s", len(removed), self.cache_dir)
        return written

    def _save(self, key: PartitionKey, partition: Partition, k: int) -> bool:
        """Save partition ``key``'s kept neighbourhoods if they changed since it last did;
        whether it wrote them (a failure is said in the log)."""
        assert self.cache_dir is not None and self.sessions is not None
        kept = partition.kept
        with self.held.lock:  # no change between the table, the revision and the probes
            state = (kept.version, len(kept))
            if kept.k != k or state == kept.saved_as:
                return False
            table = kept.saved()
            if len(table.ids) == 0:
                return False
            revision = self.held.revision
            with self.sessions() as session:
                stamp = event_stamp(session, revision)
            if stamp is None:  # pruned already: no restore could recognise the file
                return False
            saved = SavedNeighbourhoods.of(partition, key, kept.k, revision, stamp, table)
        path = file_for(self.cache_dir, key, saved.k)
        try:
            save(path, saved)
        except OSError as error:
            log.warning("hub-discount neighbourhoods not saved to %s: %s", path, error)
            return False
        kept.saved_as = state
        return True

    def _restore(self, key: PartitionKey, partition: Partition, k: int) -> int | None:
        """Restore partition ``key``'s saved neighbourhoods (``_saved``; those queries
        computed meanwhile stay) when no pass went through it since its last change, the
        file is not one tried before, and it keeps more than what the partition's passes
        kept (a restore, or a pass stopped by a change); the count kept, or None."""
        assert self.cache_dir is not None
        path = file_for(self.cache_dir, key, k)
        if self.sessions is None or partition.kept.passed or not path.is_file():
            return None
        stamp = path.stat()
        seen = (stamp.st_mtime_ns, stamp.st_size, stamp.st_ino)
        if self._restores_tried.get(key) == seen:
            return None
        self._restores_tried[key] = seen
        saved = load(path, key, k)
        if saved is None:
            return None
        with self.held.lock:  # the partition as of the revision
            version, revision = partition.kept.version, self.held.revision
        with self.sessions() as session:
            touched = None
            if event_stamp(session, saved.revision) == saved.stamp:  # this database's feed
                touched = models_touched(session, saved.revision, revision)
        restored = None if touched is None else restore(partition, saved, touched, version)
        if restored is None:
            log.info("saved hub-discount neighbourhoods of %s (revision %d) not restored at "
                     "revision %d", key, saved.revision, revision)
        else:
            log.info("hub-discount neighbourhoods of %d models of %s restored (revision %d, "
                     "%d models changed since)", restored, key, saved.revision,
                     0 if touched is None else len(touched))
            kept = partition.kept  # no need to write back what the file holds
            kept.saved_as = (kept.version, len(kept))
        return restored

    def wanted(self, k: int) -> bool:
        """Whether ``keep`` would keep more: a partition large enough to keep them has
        changed since a pass last went through it, and holds fewer than half or its last
        pass was stopped by a change (``_kept.KeptNeighbourhoods.wanted``)."""
        return k > 0 and any(
            partition.kept.wanted(k, partition.size)
            for _, partition in self._models())

    def share_kept(self, k: int) -> float:
        """The share of models, in partitions large enough to keep them, whose neighbourhood
        is kept (1.0 with none such, or the discount off)."""
        if k < 1:
            return 1.0
        sizes = [
            (min(len(partition.kept), held), held)
            for _, partition in self._models()
            if (held := partition.size) >= k + 2
        ]
        total = sum(held for _, held in sizes)
        return sum(kept for kept, _ in sizes) / total if total else 1.0
