"""Doorbells: the commit that creates work wakes whoever waits for that work, at once.

Three kinds of work are written to the database by one process and done by another thread
or process: a queued job (idle workers), a change-feed event (each API process's search
index) and a webhook delivery (the deliverers). Looked for on a timer alone
(``SHAPESEARCH_POLL_INTERVAL`` and ``SHAPESEARCH_INDEX_SYNC_INTERVAL``, 1 s each), an upload
on an idle service would wait out most of a second before its describe began
(``bench/upload_to_ready.py``). So each has a bell:

* the writer calls ``announce(session, bell)`` inside its transaction; SQLAlchemy's
  ``after_commit`` hook then rings the bell in this process, so nothing rings for work
  that was rolled back;
* on PostgreSQL the same transaction sends ``NOTIFY <bell.channel>``, which the server
  delivers only if it commits, and a ``Listener`` in every other process rings its own bell
  of that channel;
* on a SQLite file, processes of one machine share it (``serve`` with several API
  processes, or ``serve --no-worker`` beside ``shapesearch worker``): each process's
  ``Listener`` binds a Unix datagram socket in a folder of its own for that file
  (``_Neighbours``), and the commit's hook, after ringing here, sends the channel's name to
  every socket there.

Timers stay the fallback: a ring that is lost (a listener reconnecting, a job whose back-off
ends, a platform without Unix sockets) costs at most one interval, never work. A waiter
clears the bell *before* it looks for work, so a ring during the look is kept for its next
wait.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import logging
import os
import secrets
import socket
import tempfile
import threading
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import psycopg
from sqlalchemy import event, text
from sqlalchemy.engine import URL, Engine
from sqlalchemy.orm import Session

from app.observability.logs import Outage

__all__ = ["FEED", "JOBS", "WEBHOOKS", "Doorbell", "Listener", "announce"]

log = logging.getLogger("shapesearch.doorbells")

_ANNOUNCED = "shapesearch.announced"  # session.info key: the bells its commit rings
_NEIGHBOURS = "shapesearch.neighbours"  # session.info key: the SQLite file's _Neighbours
_NO_CHANNEL = ""  # a datagram that rings no bell: it finds the sockets of gone processes


class Doorbell:
    """A wake-up for threads that wait for one kind of work: ``ring`` from anywhere,
    ``clear`` then look then ``wait`` in the waiter.

    Parameters
    ----------
    channel : str
        The name that carries its rings between processes (PostgreSQL's ``NOTIFY``
        channel; the datagram between processes on one SQLite file).
    """

    def __init__(self, channel: str) -> None:
        self.channel = channel
        self._rung = threading.Event()

    def ring(self) -> None:
        """Wake every waiting thread (and the next one to wait)."""
        self._rung.set()

    def clear(self) -> None:
        """Forget earlier rings: called just before looking for work, which finds whatever
        they announced."""
        self._rung.clear()

    def wait(self, timeout: float) -> bool:
        """Wait until rung or ``timeout`` seconds; True if rung."""
        return self._rung.wait(timeout)


#: This process's bells, rung by its own commits and by its ``Listener``.
JOBS = Doorbell("shapesearch_jobs")  # a job was queued: idle workers claim it
FEED = Doorbell("shapesearch_feed")  # the change feed moved: search indexes sync
WEBHOOKS = Doorbell("shapesearch_webhooks")  # a delivery was queued: deliverers send it


def announce(session: Session, bell: Doorbell) -> None:
    """Ring ``bell`` when ``session``'s transaction commits, here and in every process that
    listens on its channel (PostgreSQL, or a SQLite file on this machine)."""
    announced: set[Doorbell] = session.info.setdefault(_ANNOUNCED, set())
    if bell in announced:
        return
    announced.add(bell)
    bind = session.get_bind()
    if bind.dialect.name == "postgresql":
        session.execute(text(f"NOTIFY {bell.channel}"))
    elif (neighbours := _Neighbours.of(bind.engine.url)) is not None:
        session.info[_NEIGHBOURS] = neighbours


@event.listens_for(Session, "after_commit")
def _ring_after_commit(session: Session) -> None:
    bells = session.info.pop(_ANNOUNCED, ())
    for bell in bells:
        bell.ring()
    neighbours = session.info.pop(_NEIGHBOURS, None)
    if neighbours is not None:
        neighbours.ring([bell.channel for bell in bells])


@event.listens_for(Session, "after_rollback")
def _forget_after_rollback(session: Session) -> None:
    session.info.pop(_ANNOUNCED, None)
    session.info.pop(_NEIGHBOURS, None)


class _Neighbours:
    """The processes of this machine on one SQLite file, reached by Unix datagram sockets.

    Each process's ``Listener`` binds a socket in ``folder`` (in the temporary directory,
    named by a hash of the file's path: a socket's path must stay under about 100 bytes, and
    a data directory's may not), and ``ring`` sends a channel's name to every socket there,
    this process's own included (as PostgreSQL delivers a ``NOTIFY`` to every listener: a
    second ring of a bell just rung costs at most one look). A socket whose process is gone
    refuses the datagram and is removed; a new listener sends every socket there an empty
    datagram first, so that a process killed before a restart leaves nothing behind. The
    folder is the user's own (0700): one left by another user is not used, and the timers
    serve.
    """

    def __init__(self, folder: Path) -> None:
        self.folder = folder

    @staticmethod
    @functools.cache
    def of(url: URL) -> _Neighbours | None:
        """The neighbours on the SQLite file of ``url``; None for another database, an
        in-memory one, or a platform without Unix sockets."""
        database = url.database or ""
        if url.get_backend_name() != "sqlite" or not hasattr(socket, "AF_UNIX"):
            return None
        if database in ("", ":memory:") or database.startswith("file:"):
            return None
        key = hashlib.sha256(str(Path(database).resolve()).encode()).hexdigest()[:16]
        return _Neighbours(Path(tempfile.gettempdir()) / f"shapesearch-bells-{key}")

    def bind(self) -> socket.socket:
        """A new socket of this process in the folder (made if missing), after removing
        those of processes that are gone; OSError if the folder is not this user's own."""
        listening = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
        try:
            self._bind_in_folder(listening)
        except OSError:
            listening.close()
            raise
        self.ring([_NO_CHANNEL])  # no bell answers it; a gone process's socket refuses it
        return listening

    def _bind_in_folder(self, listening: socket.socket) -> None:
        path = str(self.folder / f"{os.getpid()}-{secrets.token_hex(4)}")
        for attempt in range(2):  # the last one out may take the folder away meanwhile
            self.folder.mkdir(mode=0o700, exist_ok=True)
            if self.folder.stat().st_uid != os.getuid():
                raise PermissionError(f"{self.folder} belongs to another user")
            try:
                listening.bind(path)
                return
            except FileNotFoundError:
                if attempt:
                    raise

    def unbind(self, listening: socket.socket) -> None:
        """Close and remove the socket, and the folder if it was the last one there."""
        path = listening.getsockname()
        listening.close()
        Path(path).unlink(missing_ok=True)
        with contextlib.suppress(OSError):  # another process's socket is still there
            self.folder.rmdir()

    def ring(self, channels: Sequence[str]) -> None:
        """Send each of ``channels`` to every listening socket; never raises."""
        try:
            peers = [str(path) for path in self.folder.iterdir()]
        except OSError:  # no folder: nobody listens
            return
        with socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM) as sender:
            sender.setblocking(False)
            for peer in peers:
                self._send(sender, peer, channels)

    @staticmethod
    def _send(sender: socket.socket, peer: str, channels: Sequence[str]) -> None:
        for channel in channels:
            try:
                sender.sendto(channel.encode(), peer)
            except (ConnectionRefusedError, FileNotFoundError):
                Path(peer).unlink(missing_ok=True)  # its process is gone
                return
            except OSError:  # its queue is full: it has rings to read already
                return


class Listener:
    """A thread that rings each of ``bells`` when another process announces its channel:
    a ``NOTIFY`` on PostgreSQL, a datagram on a SQLite file (``start`` does nothing on
    another database or platform).

    On PostgreSQL it holds one connection of its own, outside the engine's pool, and
    reconnects after ``retry_seconds`` when the server goes away (meanwhile the timers
    serve). A channel belongs to the database, not to a schema: deployments that share a
    database wake each other's waiters for nothing, which costs each of them one look.
    """

    def __init__(
        self, engine: Engine, bells: Sequence[Doorbell], *, retry_seconds: float = 5.0
    ) -> None:
        self.engine = engine
        self.bells = {bell.channel: bell for bell in bells}
        self.retry_seconds = retry_seconds
        self.stop_event = threading.Event()
        self.thread: threading.Thread | None = None
        self.backend_pid: int | None = None  # the server process of its connection

    def start(self) -> None:
        if not self.bells:
            return
        if self.engine.dialect.name == "postgresql":
            run = self._run
        elif (neighbours := _Neighbours.of(self.engine.url)) is not None:
            run = functools.partial(self._run_neighbours, neighbours)
        else:
            return
        self.thread = threading.Thread(target=run, name="doorbells", daemon=True)
        self.thread.start()

    def stop(self) -> None:
        self.stop_event.set()
        if self.thread is not None:
            # It sees the stop within a quarter of a second; a connect in progress may take
            # longer, and the thread is a daemon: it is not waited for.
            self.thread.join(timeout=2.0)

    def _run(self) -> None:
        outage = Outage(log, "doorbells: listening (the timers serve meanwhile)")
        while not self.stop_event.is_set():
            try:
                with self._connect() as connection:
                    for channel in self.bells:
                        connection.execute(f"LISTEN {channel}")
                    outage.end()
                    for bell in self.bells.values():
                        bell.ring()  # work announced while nobody listened
                    self.backend_pid = connection.info.backend_pid
                    self._relay(connection)
            except psycopg.Error as error:
                outage.report(error)
                self.stop_event.wait(self.retry_seconds)

    def _connect(self) -> psycopg.Connection[Any]:
        url = self.engine.url.set(drivername="postgresql")
        conninfo = url.render_as_string(hide_password=False)
        return psycopg.connect(conninfo, autocommit=True, connect_timeout=10)

    def _run_neighbours(self, neighbours: _Neighbours) -> None:
        try:
            listening = neighbours.bind()
        except OSError as error:
            log.warning("doorbells: no socket in %s (%s); the timers serve",
                        neighbours.folder, error)
            return
        try:
            listening.settimeout(0.25)  # to notice ``stop``
            for bell in self.bells.values():
                bell.ring()  # work announced before this socket was there
            while not self.stop_event.is_set():
                try:
                    channel = listening.recv(256).decode(errors="replace")
                except TimeoutError:
                    continue
                if (rung := self.bells.get(channel)) is not None:
                    rung.ring()
        finally:
            neighbours.unbind(listening)

    def _relay(self, connection: psycopg.Connection[Any]) -> None:
        # Wake up four times a second to notice ``stop`` (whoever stops it waits for this
        # connection to close); a notification ends the wait at once.
        while not self.stop_event.is_set():
            for notification in connection.notifies(timeout=0.25, stop_after=1):
                self.bells[notification.channel].ring()
