"""Doorbells: the commit that creates work wakes whoever waits for that work, at once.

Three kinds of work are written to the database by one process and done by another thread
or process, which used to look for it on a timer (``SHAPESEARCH_POLL_INTERVAL`` and
``SHAPESEARCH_INDEX_SYNC_INTERVAL``, 1 s each): a queued job (idle workers), a change-feed
event (each API process's search index) and a webhook delivery (the deliverers). An upload
on an idle service waited out most of a second before its describe began
(``bench/upload_to_ready.py``). Now each has a bell:

* the writer calls ``announce(session, bell)`` inside its transaction; SQLAlchemy's
  ``after_commit`` hook then rings the bell in this process, so nothing rings for work
  that was rolled back;
* on PostgreSQL the same transaction sends ``NOTIFY <bell.channel>``, which the server
  delivers only if it commits, and a ``Listener`` in every other process rings its own bell
  of that channel.

Timers stay the fallback: a ring that is lost (a listener reconnecting, a job whose back-off
ends, a separate process on SQLite) costs at most one interval, never work. A waiter clears
the bell *before* it looks for work, so a ring during the look is kept for its next wait.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Sequence
from typing import Any

import psycopg
from sqlalchemy import event, text
from sqlalchemy.engine import Engine
from sqlalchemy.orm import Session

from app.observability.logs import Outage

__all__ = ["FEED", "JOBS", "WEBHOOKS", "Doorbell", "Listener", "announce"]

log = logging.getLogger("shapesearch.doorbells")

_ANNOUNCED = "shapesearch.announced"  # session.info key: the bells its commit rings


class Doorbell:
    """A wake-up for threads that wait for one kind of work: ``ring`` from anywhere,
    ``clear`` then look then ``wait`` in the waiter.

    Parameters
    ----------
    channel : str
        The PostgreSQL ``NOTIFY`` channel that carries its rings between processes.
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
    """Ring ``bell`` when ``session``'s transaction commits, here and, on PostgreSQL, in
    every process that listens on its channel."""
    announced: set[Doorbell] = session.info.setdefault(_ANNOUNCED, set())
    if bell in announced:
        return
    announced.add(bell)
    if session.get_bind().dialect.name == "postgresql":
        session.execute(text(f"NOTIFY {bell.channel}"))


@event.listens_for(Session, "after_commit")
def _ring_after_commit(session: Session) -> None:
    for bell in session.info.pop(_ANNOUNCED, ()):
        bell.ring()


@event.listens_for(Session, "after_rollback")
def _forget_after_rollback(session: Session) -> None:
    session.info.pop(_ANNOUNCED, None)


class Listener:
    """A thread that rings each of ``bells`` on a ``NOTIFY`` of its channel (PostgreSQL
    only: ``start`` does nothing on another database).

    It holds one connection of its own, outside the engine's pool, and reconnects after
    ``retry_seconds`` when the server goes away (meanwhile the timers serve). A channel
    belongs to the database, not to a schema: deployments that share a database wake each
    other's waiters for nothing, which costs each of them one look.
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
        if self.engine.dialect.name != "postgresql" or not self.bells:
            return
        self.thread = threading.Thread(target=self._run, name="doorbells", daemon=True)
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

    def _relay(self, connection: psycopg.Connection[Any]) -> None:
        # Wake up four times a second to notice ``stop`` (whoever stops it waits for this
        # connection to close); a notification ends the wait at once.
        while not self.stop_event.is_set():
            for notification in connection.notifies(timeout=0.25, stop_after=1):
                self.bells[notification.channel].ring()
