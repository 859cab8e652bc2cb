"""``shapesearch import``: upload a catalogue (a folder, .zip or .tar) through the HTTP API.

It is a client of the service, like any PLM connector:

    1. stream the shape files (by extension) of the folder or archive: each one is read
       when its upload starts and dropped when it ends, at most ``2 * --concurrency`` at a
       time, so memory does not grow with the catalogue (``bench/import_memory.py``);
    2. read the tenant's existing models once (GET /v1/models, paged) to know which
       external ids already hold which sha256: those files are skipped, so a second run
       uploads nothing and an interrupted run resumes where it stopped;
    3. PUT /v1/models/by-external-id/{id} each new or changed file (``--concurrency``
       threads); ``httpx-retries`` retries 429/502/503/504 and connection errors with
       jittered exponential backoff, honouring Retry-After; other 4xx answers are refusals
       with the service's reason. A PUT by external id is safe to repeat: the same file
       again is a 200 (or the revision already pending), never a second model, so no
       Idempotency-Key is needed (the service reads those on POST /v1/models only). Every
       PUT says background=true: the import's jobs take turns with the tenant's other
       uploads instead of holding them up (``app.jobs.turns``). A 507
       (the service's storage is full) stops the sending: no later file could be stored,
       and each would be sent whole to be refused; those files are reported as not sent;
    4. an assembly file sent with ``--assembly split`` (or that the service's default
       splits) is asked for its parts (GET /v1/models/{id}/parts): the report gives the
       parts and the instances found, and the summary their totals;
    5. with ``--wait``, follow every accepted model to ready or failed;
    6. write a CSV report (one row per file) and exit non-zero if anything was refused
       or failed.
"""

from __future__ import annotations

import csv
import hashlib
import json
import lzma
import os
import re
import sys
import tarfile
import threading
import time
import zipfile
import zlib
from collections import Counter
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import Future, ThreadPoolExecutor
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path, PurePosixPath
from typing import Any
from urllib.parse import quote

import httpx
from httpx_retries import Retry, RetryTransport

from core.io import SUPPORTED_FORMATS

__all__ = [
    "ImportOptions", "Outcome", "SourceItem", "open_sources", "run_import", "upload_all",
]

CAD_EXTENSIONS = ("step", "stp", "iges", "igs")
SHAPE_EXTENSIONS = frozenset((*SUPPORTED_FORMATS, *CAD_EXTENSIONS))
RETRY_STATUSES = (429, 502, 503, 504)
STORAGE_FULL = 507  # the service's storage is full: stop sending
NOT_SENT = ("not sent: the service's storage is full (507); free space and run the import "
            "again (what was stored is skipped)")
REPORT_FIELDS = ["path", "external_id", "sha256", "outcome", "http_status", "model_id", "parts",
                 "instances", "detail"]
# the service's formats that can hold an assembly (app.ingest.assemblies.ASSEMBLY_FORMATS)
ASSEMBLY_EXTENSIONS = frozenset(("glb", "gltf", "3mf", "obj", *CAD_EXTENSIONS))
# the service's default SHAPESEARCH_MAX_UPLOAD_BYTES (a larger file would get 413); not read
# from app.settings, whose pydantic would add 13 MB to the importer (a test keeps them equal)
DEFAULT_MAX_FILE_BYTES = 64 * 1024 * 1024
# what reading one file or archive member can raise (a truncated or corrupt archive, a
# compression method zipfile does not know): that file fails, the import goes on
READ_ERRORS = (OSError, EOFError, zipfile.BadZipFile, zlib.error, lzma.LZMAError,
               NotImplementedError)


@dataclass(frozen=True)
class SourceItem:
    """One shape file of the catalogue, not read yet.

    ``read`` returns its bytes (called by the thread that uploads it, so that only the
    files being uploaded are in memory); ``refusal`` says why it must not be uploaded at
    all (larger than the upload limit, an unsafe name, encrypted), and then ``read`` is
    never called.
    """

    path: str  # relative, POSIX, inside the folder or archive
    size: int  # bytes, as the file system or the archive declares it
    read: Callable[[], bytes]
    refusal: str | None = None


@dataclass(slots=True)  # one per file, kept for the report
class Outcome:
    path: str
    external_id: str
    sha256: str  # "" when the file was not read
    outcome: str  # accepted | updated | skipped | refused | failed | ready
    http_status: int | None = None
    model_id: str | None = None
    detail: str = ""
    parts: int | None = None  # an assembly's distinct parts; None: not split
    instances: int | None = None  # and their placements


@dataclass
class ImportOptions:
    url: str
    key: str | None = None
    external_id: str = "path"  # path | stem
    metadata: Path | None = None
    concurrency: int = 4
    wait: bool = False
    report: Path = Path("import-report.csv")
    timeout: float = 60.0
    retries: int = 5
    wait_timeout: float = 3600.0
    progress: bool = True
    units: str | None = None  # mm, cm, m or in: the units of every file's coordinates
    assembly: str | None = None  # split | whole; None: the service's default
    max_file_bytes: int = DEFAULT_MAX_FILE_BYTES
    extra: dict[str, Any] = field(default_factory=dict)


def _wanted(name: str) -> bool:
    parts = PurePosixPath(name).parts
    # hidden files and macOS resource forks; ".." is not hidden but unsafe (refused, reported)
    if any(part.startswith((".", "__MACOSX")) and part != ".." for part in parts):
        return False
    return PurePosixPath(name).suffix.lower().lstrip(".") in SHAPE_EXTENSIONS


def _unsafe(name: str) -> bool:
    """An archive name that climbs out of the archive (``..``), is absolute, or names a
    Windows drive: its external id would be a path outside the catalogue."""
    parts = re.split(r"[\\/]", name)
    return name.startswith(("/", "\\")) or ".." in parts or parts[0].endswith(":")


def _refusal(name: str, size: int, max_bytes: int) -> str | None:
    if _unsafe(name):
        return "an unsafe path in the archive (absolute or with ..): not uploaded"
    if size > max_bytes:
        return f"{size} bytes is larger than the upload limit of {max_bytes} bytes"
    return None


def _capped(read: Callable[[int], bytes], max_bytes: int) -> bytes:
    """At most ``max_bytes``: a file that grew, or an archive member longer than its header
    says, is refused instead of being read whole."""
    content = read(max_bytes + 1)
    if len(content) > max_bytes:
        raise OSError(f"more than the upload limit of {max_bytes} bytes")
    return content


def _folder_items(root: Path, exclude: Path | None, max_bytes: int) -> Iterator[SourceItem]:
    # os.walk, sorted one directory at a time: the order is stable and only one
    # directory's listing is held, whatever the size of the tree
    skip = exclude.resolve() if exclude is not None else None
    for directory, subdirs, files in os.walk(root):
        subdirs.sort()
        for name in sorted(files):
            file = Path(directory, name)
            relative = file.relative_to(root).as_posix()
            if not _wanted(relative) or not file.is_file():
                continue
            if skip is not None and file.resolve() == skip:
                continue
            size = file.stat().st_size

            def read(file: Path = file) -> bytes:
                with file.open("rb") as handle:
                    return _capped(handle.read, max_bytes)

            yield SourceItem(relative, size, read, _refusal(relative, size, max_bytes))


def _zip_items(archive: zipfile.ZipFile, max_bytes: int) -> Iterator[SourceItem]:
    lock = threading.Lock()  # the members are read through one shared file handle
    for info in sorted(archive.infolist(), key=lambda i: i.filename):
        if info.is_dir() or not _wanted(info.filename):
            continue
        refusal = _refusal(info.filename, info.file_size, max_bytes)
        if refusal is None and info.flag_bits & 0x1:
            refusal = "an encrypted archive member: not uploaded"

        def read(info: zipfile.ZipInfo = info) -> bytes:
            with lock, archive.open(info) as member:
                return _capped(member.read, max_bytes)

        yield SourceItem(info.filename, info.file_size, read, refusal)


def _returning(content: bytes) -> Callable[[], bytes]:
    """A reader of content already read (a stream's member cannot be read again)."""
    return lambda: content


def _tar_items(archive: tarfile.TarFile, max_bytes: int) -> Iterator[SourceItem]:
    # stream mode ("r|*"): one pass, member by member, also through .tar.gz/.bz2/.xz where
    # going back to an earlier member would decompress from the start again. A member can
    # only be read while the stream is at it, so it is read here, when the consumer asks
    # for the next item (the consumer holds at most 2 x concurrency of them).
    try:
        while (member := archive.next()) is not None:
            # Stream mode would keep every header it has seen (TarFile.members, not in the
            # stubs).
            archive.members.clear()  # type: ignore[attr-defined]
            if not member.isfile() or not _wanted(member.name):
                continue
            refusal = _refusal(member.name, member.size, max_bytes)
            content = b""
            if refusal is None:
                extracted = archive.extractfile(member)
                content = _capped(extracted.read, max_bytes) if extracted else b""
            yield SourceItem(member.name, member.size, _returning(content), refusal)
    except (tarfile.TarError, *READ_ERRORS) as error:
        name = os.fsdecode(archive.name) if archive.name is not None else "the archive"
        raise ValueError(f"{name}: the archive cannot be read on: {error}") from error


@contextmanager
def open_sources(
    path: Path, exclude: Path | None = None, max_bytes: int = DEFAULT_MAX_FILE_BYTES
) -> Iterator[Iterator[SourceItem]]:
    """The shape files of a folder (recursively), a .zip or a .tar(.gz/.bz2/.xz), lazily;
    an archive stays open until the block ends (the uploads read from it until then).

    Parameters
    ----------
    path : the folder or archive.
    exclude : a file not to import (the metadata sidecar when it lives in the folder).
    max_bytes : the service's upload limit: larger files are refused without being read.
    """
    if path.is_dir():
        yield _folder_items(path, exclude, max_bytes)
    elif zipfile.is_zipfile(path):
        with zipfile.ZipFile(path) as archive:
            yield _zip_items(archive, max_bytes)
    elif tarfile.is_tarfile(path):
        with tarfile.open(path, mode="r|*") as archive:
            yield _tar_items(archive, max_bytes)
    else:
        raise ValueError(f"{path} is not a folder, a .zip or a .tar archive")


def _external_id(path: str, mode: str) -> str:
    return PurePosixPath(path).stem if mode == "stem" else path


def load_sidecar(path: Path) -> dict[str, dict[str, Any]]:
    """Metadata per key (external id, relative path or file name).

    CSV: a column ``external_id`` (or ``path`` or ``file``) and one column per metadata key.
    JSON: an object ``{key: {metadata}}``.
    """
    if path.suffix.lower() == ".json":
        data = json.loads(path.read_text(encoding="utf-8"))
        if not isinstance(data, dict) or not all(isinstance(v, dict) for v in data.values()):
            raise ValueError("the JSON sidecar must be an object of objects")
        return {str(k): v for k, v in data.items()}
    with path.open(newline="", encoding="utf-8") as handle:
        reader = csv.DictReader(handle)
        key_column = next(
            (c for c in ("external_id", "path", "file") if c in (reader.fieldnames or [])), None
        )
        if key_column is None:
            raise ValueError("the CSV sidecar needs an external_id, path or file column")
        return {
            row[key_column]: {k: v for k, v in row.items() if k != key_column and v != ""}
            for row in reader
        }


def make_client(
    options: ImportOptions, transport: httpx.BaseTransport | None = None
) -> httpx.Client:
    """httpx whose transport retries (``httpx-retries``): 429, 502, 503, 504 and connection
    errors, on GET and PUT, after ``Retry-After`` when the service sends one and otherwise
    after a fully jittered exponential backoff (so that the threads do not retry in step);
    the last answer is returned when the retries are spent. Nothing else is retried: a 4xx
    is the service's verdict on the file. ``transport``: the one under the retries (tests)."""
    headers = {"Authorization": f"Bearer {options.key}"} if options.key else {}
    limits = httpx.Limits(max_connections=max(4, options.concurrency * 2))
    retry = Retry(
        total=options.retries, backoff_factor=0.25, backoff_jitter=1.0, max_backoff_wait=60.0,
        status_forcelist=RETRY_STATUSES, allowed_methods=("GET", "PUT"),
    )
    return httpx.Client(
        base_url=options.url.rstrip("/"), headers=headers, timeout=options.timeout,
        transport=RetryTransport(
            transport=transport or httpx.HTTPTransport(limits=limits), retry=retry
        ),
    )


def _existing(client: httpx.Client) -> dict[str, tuple[str, str]]:
    """external id -> (model id, sha256) of every model of the tenant."""
    found: dict[str, tuple[str, str]] = {}
    cursor = None
    while True:
        params: dict[str, Any] = {"limit": 500}
        if cursor:
            params["cursor"] = cursor
        response = client.request("GET", "/v1/models", params=params)
        response.raise_for_status()
        page = response.json()
        for model in page["items"]:
            if model["external_id"] is not None:
                found[model["external_id"]] = (model["id"], model["file"]["sha256"])
        cursor = page["next_cursor"]
        if cursor is None:
            return found


def _problem_detail(response: httpx.Response) -> str:
    try:
        body = response.json()
        return str(body.get("detail") or body.get("title") or response.text)[:500]
    except ValueError:
        return response.text[:500]


def _upload(
    client: httpx.Client, path: str, content: bytes, sha256: str, external_id: str,
    meta: dict[str, Any] | None, units: str | None = None, assembly: str | None = None,
) -> Outcome:
    # A bulk load: its jobs take turns with the tenant's other uploads (app.jobs.turns).
    data = {"background": "true"}
    if meta:
        data["metadata"] = json.dumps(meta)
    if units is not None:
        data["units"] = units
    if assembly is not None:
        data["assembly"] = assembly
    filename = PurePosixPath(path).name
    try:
        response = client.request(
            "PUT",
            f"/v1/models/by-external-id/{quote(external_id, safe='')}",
            files={"file": (filename, content, "application/octet-stream")},
            data=data,
        )
    except httpx.HTTPError as error:
        return Outcome(path, external_id, sha256, "failed",
                       detail=f"{type(error).__name__}: {error}")
    if response.status_code in (200, 201, 202):
        outcome = {201: "accepted", 202: "updated", 200: "skipped"}[response.status_code]
        return Outcome(path, external_id, sha256, outcome, response.status_code,
                       response.json()["id"])
    kind = "refused" if 400 <= response.status_code < 500 else "failed"
    return Outcome(path, external_id, sha256, kind, response.status_code,
                   detail=_problem_detail(response))


class _Importer:
    """What one file needs: the client, the models already there, the sidecar."""

    def __init__(
        self, client: httpx.Client, options: ImportOptions, existing: dict[str, tuple[str, str]],
        sidecar: dict[str, dict[str, Any]],
    ) -> None:
        self.client = client
        self.options = options
        self.existing = existing
        self.sidecar = sidecar
        self.storage_full = threading.Event()

    def __call__(self, item: SourceItem) -> Outcome:
        """Read, compare and upload one file; its bytes are dropped on return."""
        external_id = _external_id(item.path, self.options.external_id)
        if item.refusal is not None:
            return Outcome(item.path, external_id, "", "refused", detail=item.refusal)
        if self.storage_full.is_set():
            return Outcome(item.path, external_id, "", "failed", detail=NOT_SENT)
        try:
            content = item.read()
        except READ_ERRORS as error:
            return Outcome(item.path, external_id, "", "failed",
                           detail=f"cannot be read: {error}")
        sha256 = hashlib.sha256(content).hexdigest()
        known = self.existing.get(external_id)
        if known is not None and known[1] == sha256:
            return Outcome(item.path, external_id, sha256, "skipped", model_id=known[0])
        meta = (self.sidecar.get(external_id) or self.sidecar.get(item.path)
                or self.sidecar.get(PurePosixPath(item.path).name))
        may_split = PurePosixPath(item.path).suffix.lower().lstrip(".") in ASSEMBLY_EXTENSIONS
        # --assembly split asks only of the formats that can hold an assembly: a loose STL
        # stays one model, not an assembly of one part.
        assembly = self.options.assembly if may_split else None
        outcome = _upload(self.client, item.path, content, sha256, external_id, meta,
                          self.options.units, assembly)
        if outcome.http_status == STORAGE_FULL:
            self.storage_full.set()
        elif outcome.model_id is not None and may_split and assembly != "whole":
            _count_parts(self.client, outcome)
        return outcome


def _count_parts(client: httpx.Client, outcome: Outcome) -> None:
    """The parts and instances of an uploaded assembly, in its outcome (none: not split).
    A failed look leaves them unknown; the upload itself stands."""
    try:
        response = client.request("GET", f"/v1/models/{outcome.model_id}/parts")
    except httpx.HTTPError:
        return
    if response.status_code != 200:
        return
    parts = response.json().get("parts") or []
    if parts:
        outcome.parts = len(parts)
        outcome.instances = sum(int(part["count"]) for part in parts)


def upload_all(
    items: Iterable[SourceItem], one: Callable[[SourceItem], Outcome], concurrency: int,
    done: Callable[[Outcome], None], outcomes: list[Outcome],
) -> None:
    """``one(item)`` for every item on ``concurrency`` threads, appending to ``outcomes``.

    ``items`` is pulled only while fewer than ``2 * concurrency`` items are queued or
    uploading (``ThreadPoolExecutor.map`` would drain it first), so a streamed catalogue
    stays streamed: at most ``2 * concurrency`` files are in memory at once. ``done`` sees
    every outcome as it comes (the progress bar).
    """
    workers = max(1, concurrency)
    slots = threading.BoundedSemaphore(2 * workers)
    lock = threading.Lock()
    errors: list[BaseException] = []

    def finished(future: Future[Outcome]) -> None:
        # the outcome is kept, not the future: a catalogue of a million files keeps a
        # million small rows for the report and nothing else
        slots.release()
        error = future.exception()
        if error is not None:
            with lock:
                errors.append(error)
            return
        outcome = future.result()
        with lock:
            outcomes.append(outcome)
        done(outcome)

    iterator = iter(items)
    with ThreadPoolExecutor(max_workers=workers) as pool:
        while not errors:  # what was done is kept (the report), also after an error
            slots.acquire()  # before the next item is pulled (a tar item holds its bytes)
            item = next(iterator, None)
            if item is None:
                break
            pool.submit(one, item).add_done_callback(finished)
    if errors:
        raise errors[0]  # a worker's unexpected error


def _wait_for(client: httpx.Client, outcome: Outcome, deadline: float) -> None:
    while time.monotonic() < deadline:
        try:
            response = client.request("GET", f"/v1/models/{outcome.model_id}")
        except httpx.HTTPError:
            time.sleep(1.0)
            continue
        body = response.json() if response.status_code == 200 else {}
        job = body.get("job") or {}
        if body.get("status") == "failed" or job.get("status") == "failed":
            outcome.outcome = "failed"
            outcome.detail = str((body.get("error") or {}).get("detail", "job failed"))
            return
        if body.get("status") == "ready" and job.get("status") in (None, "done"):
            outcome.outcome = "ready"
            return
        time.sleep(0.2)
    outcome.outcome = "failed"
    outcome.detail = "still not ready when --wait gave up"


def _write_report(path: Path, outcomes: list[Outcome]) -> None:
    with path.open("w", newline="", encoding="utf-8") as handle:
        writer = csv.writer(handle)
        writer.writerow(REPORT_FIELDS)
        for o in sorted(outcomes, key=lambda o: o.path):
            writer.writerow([o.path, o.external_id, o.sha256, o.outcome,
                             o.http_status or "", o.model_id or "",
                             "" if o.parts is None else o.parts,
                             "" if o.instances is None else o.instances, o.detail])


def _follow(client: httpx.Client, outcomes: list[Outcome], options: ImportOptions) -> None:
    """``--wait``: every accepted or updated model, to ready or failed."""
    from tqdm import tqdm

    pending = [o for o in outcomes if o.outcome in ("accepted", "updated")]
    deadline = time.monotonic() + options.wait_timeout
    lock = threading.Lock()
    with tqdm(total=len(pending), unit="model", desc="describe",
              disable=not options.progress) as wait_bar:

        def follow(outcome: Outcome) -> None:
            _wait_for(client, outcome, deadline)
            with lock:
                wait_bar.update(1)

        with ThreadPoolExecutor(max_workers=max(1, options.concurrency)) as pool:
            list(pool.map(follow, pending))


def run_import(path: Path, options: ImportOptions) -> tuple[int, Counter[str]]:
    """Import ``path``; returns the exit code and the count of each outcome."""
    from tqdm import tqdm

    sidecar = load_sidecar(options.metadata) if options.metadata else {}
    client = make_client(options)
    counts: Counter[str] = Counter()
    outcomes: list[Outcome] = []
    lock = threading.Lock()
    try:
        existing = _existing(client)
        # no total: counting the files of an archive would mean reading it twice
        bar = tqdm(unit="file", desc="import", disable=not options.progress)

        def done(result: Outcome) -> None:
            with lock:
                counts[result.outcome] += 1
                bar.update(1)
                bar.set_postfix(dict(counts))
                if result.outcome == "refused":
                    bar.write(f"refused {result.path}: {result.detail}")

        importer = _Importer(client, options, existing, sidecar)
        try:
            with open_sources(path, options.metadata, options.max_file_bytes) as items:
                upload_all(items, importer, options.concurrency, done, outcomes)
        except BaseException:
            _write_report(options.report, outcomes)  # what was uploaded before the error
            raise
        finally:
            bar.close()
        if options.wait:
            _follow(client, outcomes, options)
            counts = Counter(o.outcome for o in outcomes)
    finally:
        client.close()
    _write_report(options.report, outcomes)
    summary = ", ".join(f"{counts.get(k, 0)} {k}" for k in
                        ("accepted", "updated", "skipped", "refused", "failed", "ready"))
    print(f"{len(outcomes)} files: {summary}; report: {options.report}", file=sys.stderr)
    split = [o for o in outcomes if o.parts is not None]
    if split:
        print(f"{len(split)} assemblies split: "
              f"{sum(o.parts or 0 for o in split)} parts created, "
              f"{sum(o.instances or 0 for o in split)} instances found", file=sys.stderr)
    if importer.storage_full.is_set():
        unsent = sum(o.detail == NOT_SENT for o in outcomes)
        print(f"the service's storage is full (507): {unsent} file(s) not sent; free space "
              "and run the same command again", file=sys.stderr)
    bad = counts.get("refused", 0) + counts.get("failed", 0)
    return (1 if bad else 0), counts
