"""Waking idle workers when a job is queued, instead of letting them sleep out their poll.

An idle worker looks at the queue every ``poll_interval`` seconds (1 s). On an idle service
that wait came before every upload's describe: half a second on average, on top of about a
second of work (``bench/upload_to_ready.py``). Now the commit that makes a job visible rings
a bell:

* in the process that queued it, ``queue_job`` marks its session and SQLAlchemy's
  ``after_commit`` hook rings this process's ``DOORBELL``, so ``shapesearch serve``'s
  embedded worker claims the job at once;
* on PostgreSQL the same transaction sends ``NOTIFY shapesearch_jobs``, which the server
  delivers only if it commits, and every process with worker threads listens on that
  channel (``Listener``), so separate ``shapesearch worker`` processes wake too.

Polling stays the fallback: a ring that is lost (a listener reconnecting, a job whose back-off
ends) costs at most one poll interval, never a job. A worker clears the bell before it looks
at the queue, so a ring during that look is kept for its next wait.
"""

from __future__ import annotations

import logging
import threading
from typing import Any

import psycopg
from sqlalchemy import event, text
from sqlalchemy.engine import Engine
from sqlalchemy.orm import Session

__all__ = ["CHANNEL", "DOORBELL", "Doorbell", "Listener", "announce_job"]

log = logging.getLogger("shapesearch.doorbell")

#: The PostgreSQL channel that carries "a job was queued" between processes.
CHANNEL = "shapesearch_jobs"

_QUEUED = "shapesearch.jobs_queued"  # the session.info key: this transaction queued a job


class Doorbell:
    """A wake-up for idle worker threads: ``ring`` from anywhere, ``wait`` in a worker."""

    def __init__(self) -> None:
        self._rung = threading.Event()

    def ring(self) -> None:
        """Wake every waiting worker (and the next one to wait)."""
        self._rung.set()

    def clear(self) -> None:
        """Forget earlier rings: called just before a worker looks at the queue, which
        finds whatever they announced."""
        self._rung.clear()

    def wait(self, timeout: float) -> bool:
        """Wait until rung or ``timeout`` seconds; True if rung."""
        return self._rung.wait(timeout)


#: The bell of this process: rung by its own commits and by its ``Listener``.
DOORBELL = Doorbell()


def announce_job(session: Session) -> None:
    """Mark ``session``'s transaction as one that queued a job: its commit rings the bell
    here and, on PostgreSQL, in every listening process."""
    session.info[_QUEUED] = True
    if session.get_bind().dialect.name == "postgresql":
        session.execute(text(f"NOTIFY {CHANNEL}"))


@event.listens_for(Session, "after_commit")
def _ring_after_commit(session: Session) -> None:
    if session.info.pop(_QUEUED, False):
        DOORBELL.ring()


@event.listens_for(Session, "after_rollback")
def _forget_after_rollback(session: Session) -> None:
    session.info.pop(_QUEUED, None)


class Listener:
    """A thread that rings ``doorbell`` on each ``NOTIFY shapesearch_jobs`` (PostgreSQL
    only: ``start`` does nothing on another database).

    It holds one connection of its own, outside the engine's pool, and reconnects after
    ``retry_seconds`` when the server goes away; meanwhile the workers poll. The channel is
    the database's, not a schema's: deployments sharing a database wake each other's idle
    workers for nothing, which costs each one look at its queue.
    """

    def __init__(
        self,
        engine: Engine,
        doorbell: Doorbell = DOORBELL,
        *,
        retry_seconds: float = 5.0,
        stop: threading.Event | None = None,
    ) -> None:
        self.engine = engine
        self.doorbell = doorbell
        self.retry_seconds = retry_seconds
        self.stop_event = stop or threading.Event()
        self.thread: threading.Thread | None = None

    def start(self) -> None:
        if self.engine.dialect.name != "postgresql":
            return
        self.thread = threading.Thread(target=self._run, name="job-listener", daemon=True)
        self.thread.start()

    def stop(self) -> None:
        self.stop_event.set()
        if self.thread is not None:
            # It sees the stop within a quarter of a second; a connect in progress may take
            # longer, and the thread is a daemon: it is not waited for.
            self.thread.join(timeout=2.0)

    def _run(self) -> None:
        while not self.stop_event.is_set():
            try:
                with self._connect() as connection:
                    connection.execute(f"LISTEN {CHANNEL}")
                    self.doorbell.ring()  # a job queued while not listening
                    self._relay(connection)
            except psycopg.Error as error:
                log.warning("job listener: %s; polling until it reconnects", error)
                self.stop_event.wait(self.retry_seconds)

    def _connect(self) -> psycopg.Connection[Any]:
        url = self.engine.url.set(drivername="postgresql")
        conninfo = url.render_as_string(hide_password=False)
        return psycopg.connect(conninfo, autocommit=True, connect_timeout=10)

    def _relay(self, connection: psycopg.Connection[Any]) -> None:
        # Wake up four times a second to notice ``stop`` (a stopping pool waits for this
        # connection to close); a notification ends the wait at once.
        while not self.stop_event.is_set():
            for _ in connection.notifies(timeout=0.25, stop_after=1):
                self.doorbell.ring()
