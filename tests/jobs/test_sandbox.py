"""The sandbox: a child process with an address-space and a wall-clock limit; the parent
gets the result, the engine's own errors, or a ``too_large`` refusal, and lives on."""

from __future__ import annotations

import os
import signal
import time

import numpy as np
import pytest
import trimesh

from app.ingest.sandbox import (
    Sandbox,
    SandboxCrash,
    SandboxTimeout,
    _address_space,
    describe_limit_seconds,
)
from app.jobs.worker import describe_handler
from core.errors import InvalidShapeError, SolverError
from tests.conftest import PARTS, make_settings

GIB = 1024**3
MIB = 1024**2


def allocate(gib: float) -> int:
    return int(np.ones(int(gib * GIB) // 8).sum())


def sleep(seconds: float) -> None:
    time.sleep(seconds)


def product_into(a: np.ndarray, b: np.ndarray, out: np.ndarray) -> float:
    """A matrix product that allocates nothing in Python: only OpenBLAS's own buffers."""
    np.matmul(a, b, out=out)
    return float(out[0, 0])


def kill_myself() -> None:
    os.kill(os.getpid(), signal.SIGKILL)


def refuse() -> None:
    raise InvalidShapeError("degenerate", "all points on a line")


def fail_numerically() -> None:
    raise SolverError("no convergence")


def crash() -> None:
    raise KeyError("surprise")


def segfault() -> None:
    os.kill(os.getpid(), signal.SIGSEGV)


@pytest.mark.slow
def test_the_result_comes_back() -> None:
    assert Sandbox(4 * GIB, 60).run(allocate, 0.01) == GIB // 100 // 8


@pytest.mark.slow
def test_the_memory_limit_refuses_the_file_as_too_large() -> None:
    sandbox = Sandbox(2 * GIB, 60)
    with pytest.raises(InvalidShapeError) as refused:
        sandbox.run(allocate, 3)
    assert refused.value.reason == "too_large"
    assert "SHAPESEARCH_DESCRIBE_MEMORY_BYTES" in refused.value.message


@pytest.mark.slow
def test_the_time_limit_kills_the_child_and_refuses_the_file() -> None:
    started = time.monotonic()
    with pytest.raises(SandboxTimeout) as refused:
        Sandbox(4 * GIB, 1.0).run(sleep, 60)
    assert time.monotonic() - started < 30
    # A describe's caller takes it as any refusal; an upload's quick check can tell it apart.
    assert isinstance(refused.value, InvalidShapeError) and refused.value.reason == "too_large"
    assert "SHAPESEARCH_DESCRIBE_TIMEOUT_SECONDS" in refused.value.message


def test_the_describe_limit_grows_with_the_file_up_to_the_largest_files_limit() -> None:
    settings = make_settings("sqlite://", describe_timeout_seconds=300.0,
                             describe_timeout_base_seconds=60.0,
                             describe_timeout_seconds_per_mb=10.0)
    assert describe_limit_seconds(settings, 19_000) == pytest.approx(60.19)  # a small IGES
    assert describe_limit_seconds(settings, 10_000_000) == pytest.approx(160.0)
    assert describe_limit_seconds(settings, 64 * 2**20) == 300.0  # the upload limit: capped
    low_cap = make_settings("sqlite://", describe_timeout_seconds=30.0)
    assert describe_limit_seconds(low_cap, 1_000) == 30.0  # a cap below the base wins


@pytest.mark.slow
def test_a_killed_child_is_a_refusal_and_other_errors_keep_their_kind() -> None:
    sandbox = Sandbox(4 * GIB, 60)
    with pytest.raises(InvalidShapeError, match="memory"):
        sandbox.run(kill_myself)
    with pytest.raises(InvalidShapeError) as refused:
        sandbox.run(refuse)
    assert refused.value.reason == "degenerate" and "line" in refused.value.message
    with pytest.raises(SolverError, match="no convergence"):
        sandbox.run(fail_numerically)
    with pytest.raises(SandboxCrash, match="KeyError"):
        sandbox.run(crash)
    # A native reader that dereferences a null pointer ends its process by a signal: the
    # file is at fault, a refusal that no worker retries.
    with pytest.raises(InvalidShapeError, match="crashed \\(SIGSEGV\\).*corrupt") as crashed:
        sandbox.run(segfault)
    assert crashed.value.reason == "unparsable"


@pytest.mark.slow
def test_the_worker_describes_in_the_sandbox(tmp_path) -> None:
    """The production handler describes a real part, and refuses one that needs more
    memory than its limit as too large (the parser's ``MemoryError`` is not a corrupt file)
    without the worker process growing."""
    settings = make_settings(f"sqlite:///{tmp_path / 'db.sqlite'}")
    columns = describe_handler(settings)((PARTS / "cylinder.stl").read_bytes(), "cylinder.stl")
    assert columns["n_points"] > 0 and len(columns["descriptor"]) > 0

    tight = make_settings(f"sqlite:///{tmp_path / 'db.sqlite'}", describe_memory_bytes=64 * MIB)
    dense = trimesh.creation.icosphere(subdivisions=7).export(file_type="stl")  # 16 MB
    with pytest.raises(InvalidShapeError) as refused:
        describe_handler(tight)(dense, "sphere.stl")
    assert refused.value.reason == "too_large"


@pytest.mark.slow
def test_the_limit_counts_from_the_childs_start(tmp_path) -> None:
    """A child starts with the engine's libraries mapped, far more address space than a
    small part's describe needs; the setting is what the describe may add, so a budget
    below that start still describes the part."""
    start = Sandbox(4 * GIB, 60).run(_address_space)
    budget = 64 * MIB
    assert start > budget
    tight = make_settings(f"sqlite:///{tmp_path / 'db.sqlite'}", describe_memory_bytes=budget)
    columns = describe_handler(tight)((PARTS / "cylinder.stl").read_bytes(), "cylinder.stl")
    assert columns["n_points"] > 0


@pytest.mark.slow
def test_blas_under_a_tight_limit_is_not_a_crash() -> None:
    """OpenBLAS allocates its work buffer at a process's first product, outside Python;
    under the limit that allocation fails (the product is refused as too large, or OpenBLAS
    ends the process with exit code 1, as the describe test above saw). The child lets it
    allocate before the limit, so a product whose arrays exist already runs."""
    a, b, out = np.ones((300, 300)), np.ones((300, 300)), np.empty((300, 300))
    tight = Sandbox(memory_bytes=256 * 1024 * 1024, timeout_seconds=30)
    assert tight.run(product_into, a, b, out) == 300.0


def test_what_a_child_unpickles_is_imported_by_the_forkserver_already() -> None:
    """A child imports afresh every module of what it unpickles that its forkserver has not
    preloaded: ``_child``'s own module cost every child 63 ms (app.settings, pydantic) of an
    empty call's 104 (bench/sandbox.py). The entry point and every function the service runs
    in a sandbox must come from a preloaded module."""
    from app.ingest import describing, sandbox

    run_in_children = [
        sandbox._child, describing.ingest_columns, describing.described_columns,
        describing.quick_check,
    ]
    assert {function.__module__ for function in run_in_children} <= set(sandbox._PRELOAD)
