"""Parse and describe untrusted files in a child process with a memory and a time limit.

A shape file can be a bomb that no cheap check foresees: a parser may expand it to
gigabytes, or spin for minutes. Running that inside the API or worker process would grow it
(Python rarely hands memory back) or kill it. ``Sandbox.run(function, *args)`` instead runs
``function`` in a fresh child process that may take ``memory_bytes`` of address space beyond
what it holds when it starts (``RLIMIT_AS`` is set to the sum) and waits at most
``timeout_seconds`` for it; the parent's own memory never holds more than the input and the
(small) result.

Why beyond the start: a child begins with the engine's libraries mapped, several hundred MB
of address space that depends on the machine's BLAS and on what the parent imported (378 MB
under ``shapesearch serve`` on one machine, 820 MB under a test runner); a limit counted from
zero would leave a file whatever that start happens to leave, and a low setting would refuse
every file.

Children come from a *forkserver* that has imported the engine (and OpenCascade, when it is
installed) once, so a child starts in milliseconds without re-importing numpy/scipy/trimesh,
and without inheriting the threads and locks of the server (which a plain fork of a threaded
process would).

Outcomes, as the engine's own exceptions so that callers handle them as they always did:

* ``InvalidShapeError`` raised by ``function`` passes through unchanged;
* the memory limit (``MemoryError``, or a child killed by the kernel) -> ``too_large``;
* the wall-clock limit -> ``SandboxTimeout``, an ``InvalidShapeError`` ``too_large`` (the
  child is killed) that a caller for whom the limit is no verdict can tell apart;
* a child ended by any other signal (a native reader that crashed on the file) ->
  ``unparsable``;
* ``SolverError`` passes through (it may be transient), and so does an ``OSError`` of a
  full disk (``core.errors.NO_SPACE_ERRNOS``: ``app.storage`` tells it); any other exception
  in the child becomes ``SandboxCrash`` with the child's description of it.
"""

from __future__ import annotations

import multiprocessing
import resource
import signal
from collections.abc import Callable
from dataclasses import dataclass
from multiprocessing.connection import Connection
from typing import Any, TypeVar

import numpy as np
from scipy.linalg import blas
from threadpoolctl import threadpool_limits

from app.settings import Settings
from core.errors import NO_SPACE_ERRNOS, InvalidShapeError, SolverError

__all__ = [
    "Sandbox", "SandboxCrash", "SandboxTimeout", "describe_limit_seconds", "describe_sandbox",
    "sandbox_of",
]

T = TypeVar("T")

# What a child unpickles must be imported already, or every child imports it again: this
# module itself (``_child``; its import, app.settings with it, took 63 ms of a 104 ms empty
# call, bench/sandbox.py) and the functions that run in it (``app.ingest.describing``).
# OpenCascade too, where the cad extra is installed: its import takes about 0.5 s, which
# every STEP or IGES check and describe would pay in its child (they are parsed in the
# sandbox only, core.io.CRASHING_FORMATS). The forkserver skips a module that does not import.
_PRELOAD = [
    "core.pipeline", "core.io", "app.ingest.describing", "app.ingest.sandbox", "OCP.STEPControl",
]
_context = multiprocessing.get_context("forkserver")
_context.set_forkserver_preload(_PRELOAD)


class SandboxCrash(RuntimeError):
    """The child raised an unexpected exception (a bug, or an input nobody foresaw)."""


class SandboxTimeout(InvalidShapeError):
    """The wall-clock limit ran out and the child was killed: ``too_large`` to a describe,
    but only "not known yet" to an upload's quick check, whose limit is shorter
    (``app.api.uploads``)."""


def _warm_blas() -> None:
    """Have numpy's and scipy's OpenBLAS allocate their work buffers now, before the limit.

    OpenBLAS allocates a thread's buffer at its first matrix product, outside Python; under
    the address-space limit a refused allocation makes it end the whole process (exit code
    1, "Memory allocation still failed") instead of raising ``MemoryError``, so a file over
    the limit would look like a crash rather than be refused as too large. 256 x 256 is
    above OpenBLAS's small-matrix path, which uses no buffer.
    """
    square = np.ones((256, 256))
    square @ square
    blas.dgemm(1.0, square, square)


def _address_space() -> int:
    """This process's address space now, in bytes (Linux's ``/proc``; 0 where there is
    none, so that the limit counts from zero there)."""
    try:
        with open("/proc/self/statm") as statm:
            return int(statm.read().split()[0]) * resource.getpagesize()
    except (OSError, ValueError, IndexError):
        return 0


def _child(
    connection: Connection, memory_bytes: int, function: Callable[..., Any], args: tuple
) -> None:
    try:
        threadpool_limits(limits=1)  # one describe per child; children run side by side
        _warm_blas()
        limit = _address_space() + memory_bytes
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
        outcome: tuple[str, Any] = ("ok", function(*args))
    except InvalidShapeError as error:
        outcome = ("invalid", (error.reason, error.message))
    except SolverError as error:
        outcome = ("solver", str(error))
    except MemoryError:
        outcome = ("memory", None)
    except BaseException as error:  # reported to the parent, which decides what it means
        if isinstance(error, OSError) and error.errno in NO_SPACE_ERRNOS:
            outcome = ("no-space", (error.errno, str(error)[:2000]))  # storage_full sees it
        else:
            outcome = ("crash", f"{type(error).__name__}: {error}"[:2000])
    try:
        connection.send(outcome)
    except MemoryError:  # the result itself does not fit: the input was too large
        connection.send(("memory", None))
    finally:
        connection.close()


@dataclass(frozen=True)
class Sandbox:
    """Runs functions in a child process limited to ``memory_bytes`` of address space beyond
    its start and ``timeout_seconds`` of wall-clock time."""

    memory_bytes: int
    timeout_seconds: float

    def run(self, function: Callable[..., T], *args: Any) -> T:
        """``function(*args)`` in a child; ``function`` and ``args`` must be picklable."""
        receiver, sender = _context.Pipe(duplex=False)
        child = _context.Process(
            target=_child, args=(sender, self.memory_bytes, function, args), daemon=True
        )
        child.start()
        sender.close()
        try:
            if not receiver.poll(self.timeout_seconds):
                raise self._too_slow()
            try:
                kind, payload = receiver.recv()
            except EOFError:  # the child died without a word: killed, or crashed hard
                child.join(5)
                raise self._died(child.exitcode) from None
        finally:
            receiver.close()
            if child.is_alive():
                child.kill()
            child.join()
        return self._result(kind, payload)

    def _result(self, kind: str, payload: Any) -> Any:
        if kind == "ok":
            return payload
        if kind == "invalid":
            raise InvalidShapeError(*payload)
        if kind == "solver":
            raise SolverError(payload)
        if kind == "memory":
            raise self._too_big()
        if kind == "no-space":
            raise OSError(*payload)
        raise SandboxCrash(payload)

    def _too_big(self) -> InvalidShapeError:
        return InvalidShapeError(
            "too_large",
            f"describing this file needs more than the limit of {self.memory_bytes:,} bytes "
            "of memory (SHAPESEARCH_DESCRIBE_MEMORY_BYTES): simplify the mesh or thin the "
            "cloud first",
        )

    def _too_slow(self) -> SandboxTimeout:
        return SandboxTimeout(
            "too_large",
            f"describing this file took longer than its limit of {self.timeout_seconds:.3g} s "
            "(SHAPESEARCH_DESCRIBE_TIMEOUT_BASE_SECONDS plus SHAPESEARCH_DESCRIBE_TIMEOUT_"
            "SECONDS_PER_MB a MB, at most SHAPESEARCH_DESCRIBE_TIMEOUT_SECONDS): simplify the "
            "mesh or thin the cloud first "
            "(a small file that takes this long is probably corrupt: export it again)",
        )

    def _died(self, exitcode: int | None) -> InvalidShapeError | SandboxCrash:
        if exitcode is not None and exitcode == -signal.SIGKILL:  # the kernel's OOM killer
            return self._too_big()
        if exitcode is not None and exitcode < 0:
            # A signal: a native reader crashed on the file (OpenCascade on a malformed STEP,
            # lazrs on a lying LAZ). The file, not the moment, is at fault: a refusal, which
            # a worker does not retry.
            return InvalidShapeError(
                "unparsable",
                f"the process reading this file crashed ({_signal_name(-exitcode)}): the file "
                "is probably corrupt; export the part again",
            )
        return SandboxCrash(f"the describing process ended with exit code {exitcode}")


def _signal_name(number: int) -> str:
    """``SIGSEGV`` for 11; ``signal 40`` for a number without a name."""
    try:
        return signal.Signals(number).name
    except ValueError:
        return f"signal {number}"


def describe_limit_seconds(settings: Settings, size_bytes: int) -> float:
    """The wall-clock limit of describing a file of ``size_bytes``:
    ``describe_timeout_base_seconds`` plus ``describe_timeout_seconds_per_mb`` a MB, at most
    ``describe_timeout_seconds``. Valid files need far less (at most 3 s plus 2.3 s a MB
    here, ``bench/describe_by_size.py``, binary PLY the slowest a MB); a reader that hangs
    on a small corrupt file holds a worker or a search slot for a minute instead of five."""
    grown = (settings.describe_timeout_base_seconds
             + settings.describe_timeout_seconds_per_mb * size_bytes / 1e6)
    return min(settings.describe_timeout_seconds, grown)


def describe_sandbox(settings: Settings, size_bytes: int) -> Sandbox:
    """The sandbox that describes a file of ``size_bytes`` (a job's or a search's)."""
    return sandbox_of(settings, describe_limit_seconds(settings, size_bytes))


def sandbox_of(settings: Settings, timeout_seconds: float) -> Sandbox:
    """A sandbox with the service's memory limit and ``timeout_seconds`` (a describe's
    limit, ``describe_sandbox``, or an upload's quick check's)."""
    return Sandbox(settings.describe_memory_bytes, timeout_seconds)
