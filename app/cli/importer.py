"""``shapesearch import``: upload a catalogue (a folder, .zip or .tar) through the HTTP API.

It is a client of the service, like any PLM connector:

    1. list the shape files (by extension) of the folder or archive;
    2. read the tenant's existing models once (GET /v1/models, paged) to know which
       external ids already hold which sha256: those files are skipped, so a second run
       uploads nothing and an interrupted run resumes where it stopped;
    3. PUT /v1/models/by-external-id/{id} each new or changed file (``--concurrency``
       threads), with retries on 429/503 and connection errors (exponential backoff,
       honouring Retry-After); 4xx answers are refusals with the service's reason;
    4. with ``--wait``, follow every accepted model to ready or failed;
    5. write a CSV report (one row per file) and exit non-zero if anything was refused
       or failed.
"""

from __future__ import annotations

import csv
import hashlib
import json
import sys
import tarfile
import threading
import time
import zipfile
from collections import Counter
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path, PurePosixPath
from typing import Any
from urllib.parse import quote

import httpx

from core.io import SUPPORTED_FORMATS

__all__ = ["ImportOptions", "Outcome", "SourceFile", "iter_sources", "run_import"]

CAD_EXTENSIONS = ("step", "stp", "iges", "igs")
SHAPE_EXTENSIONS = frozenset((*SUPPORTED_FORMATS, *CAD_EXTENSIONS))
RETRY_STATUSES = frozenset({429, 502, 503, 504})
REPORT_FIELDS = ["path", "external_id", "sha256", "outcome", "http_status", "model_id", "detail"]


@dataclass(frozen=True)
class SourceFile:
    path: str  # relative, POSIX, inside the folder or archive
    content: bytes

    @property
    def sha256(self) -> str:
        return hashlib.sha256(self.content).hexdigest()


@dataclass
class Outcome:
    source: SourceFile
    external_id: str
    outcome: str  # accepted | updated | skipped | refused | failed | ready
    http_status: int | None = None
    model_id: str | None = None
    detail: str = ""


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
    extra: dict[str, Any] = field(default_factory=dict)


def _wanted(name: str) -> bool:
    parts = PurePosixPath(name).parts
    if any(part.startswith((".", "__MACOSX")) for part in parts):
        return False
    return PurePosixPath(name).suffix.lower().lstrip(".") in SHAPE_EXTENSIONS


def iter_sources(path: Path, exclude: Path | None = None) -> Iterator[SourceFile]:
    """The shape files of a folder (recursively), a .zip or a .tar(.gz/.bz2/.xz)."""
    if path.is_dir():
        for file in sorted(p for p in path.rglob("*") if p.is_file()):
            if exclude is not None and file.resolve() == exclude.resolve():
                continue
            relative = file.relative_to(path).as_posix()
            if _wanted(relative):
                yield SourceFile(relative, file.read_bytes())
    elif zipfile.is_zipfile(path):
        with zipfile.ZipFile(path) as archive:
            for info in sorted(archive.infolist(), key=lambda i: i.filename):
                if not info.is_dir() and _wanted(info.filename):
                    yield SourceFile(info.filename, archive.read(info))
    elif tarfile.is_tarfile(path):
        with tarfile.open(path) as archive:
            for member in sorted(archive.getmembers(), key=lambda m: m.name):
                if member.isfile() and _wanted(member.name):
                    extracted = archive.extractfile(member)
                    if extracted is not None:
                        yield SourceFile(member.name, extracted.read())
    else:
        raise ValueError(f"{path} is not a folder, a .zip or a .tar archive")


def _external_id(source: SourceFile, mode: str) -> str:
    return PurePosixPath(source.path).stem if mode == "stem" else source.path


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


class _Client:
    """httpx with retries on 429/503 and connection errors."""

    def __init__(self, options: ImportOptions) -> None:
        headers = {"Authorization": f"Bearer {options.key}"} if options.key else {}
        self.http = httpx.Client(
            base_url=options.url.rstrip("/"), headers=headers, timeout=options.timeout,
            limits=httpx.Limits(max_connections=max(4, options.concurrency * 2)),
        )
        self.retries = options.retries

    def request(self, method: str, url: str, **kwargs: Any) -> httpx.Response:
        for attempt in range(self.retries + 1):
            try:
                response = self.http.request(method, url, **kwargs)
            except httpx.TransportError:
                if attempt == self.retries:
                    raise
                time.sleep(min(30.0, 0.5 * 2**attempt))
                continue
            if response.status_code not in RETRY_STATUSES or attempt == self.retries:
                return response
            retry_after = response.headers.get("retry-after", "")
            delay = float(retry_after) if retry_after.isdigit() else 0.5 * 2**attempt
            time.sleep(min(30.0, delay))
        raise AssertionError("unreachable")

    def close(self) -> None:
        self.http.close()


def _existing(client: _Client) -> dict[str, tuple[str, str]]:
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
    client: _Client, source: SourceFile, external_id: str, meta: dict[str, Any] | None,
    units: str | None = None,
) -> Outcome:
    data = {"metadata": json.dumps(meta)} if meta else {}
    if units is not None:
        data["units"] = units
    filename = PurePosixPath(source.path).name
    try:
        response = client.request(
            "PUT",
            f"/v1/models/by-external-id/{quote(external_id, safe='')}",
            files={"file": (filename, source.content, "application/octet-stream")},
            data=data,
        )
    except httpx.HTTPError as error:
        return Outcome(source, external_id, "failed", detail=f"{type(error).__name__}: {error}")
    if response.status_code in (200, 201, 202):
        outcome = {201: "accepted", 202: "updated", 200: "skipped"}[response.status_code]
        return Outcome(source, external_id, outcome, response.status_code, response.json()["id"])
    kind = "refused" if 400 <= response.status_code < 500 else "failed"
    return Outcome(source, external_id, kind, response.status_code,
                   detail=_problem_detail(response))


def _wait_for(client: _Client, outcome: Outcome, deadline: float) -> None:
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
        for o in sorted(outcomes, key=lambda o: o.source.path):
            writer.writerow([o.source.path, o.external_id, o.source.sha256, o.outcome,
                             o.http_status or "", o.model_id or "", o.detail])


def run_import(path: Path, options: ImportOptions) -> tuple[int, Counter[str]]:
    """Import ``path``; returns the exit code and the count of each outcome."""
    from tqdm import tqdm

    sidecar = load_sidecar(options.metadata) if options.metadata else {}
    sources = list(iter_sources(path, exclude=options.metadata))
    client = _Client(options)
    counts: Counter[str] = Counter()
    outcomes: list[Outcome] = []
    lock = threading.Lock()
    try:
        existing = _existing(client)
        bar = tqdm(total=len(sources), unit="file", desc="import", disable=not options.progress)

        def one(source: SourceFile) -> Outcome:
            external_id = _external_id(source, options.external_id)
            known = existing.get(external_id)
            if known is not None and known[1] == source.sha256:
                result = Outcome(source, external_id, "skipped", model_id=known[0])
            else:
                meta = (sidecar.get(external_id) or sidecar.get(source.path)
                        or sidecar.get(PurePosixPath(source.path).name))
                result = _upload(client, source, external_id, meta, options.units)
            with lock:
                counts[result.outcome] += 1
                bar.update(1)
                bar.set_postfix(dict(counts))
                if result.outcome == "refused":
                    bar.write(f"refused {source.path}: {result.detail}")
            return result

        with ThreadPoolExecutor(max_workers=max(1, options.concurrency)) as pool:
            outcomes = list(pool.map(one, sources))
        bar.close()
        if options.wait:
            pending = [o for o in outcomes if o.outcome in ("accepted", "updated")]
            deadline = time.monotonic() + options.wait_timeout
            with tqdm(total=len(pending), unit="model", desc="describe",
                      disable=not options.progress) as wait_bar:

                def follow(outcome: Outcome) -> None:
                    _wait_for(client, outcome, deadline)
                    with lock:
                        wait_bar.update(1)

                with ThreadPoolExecutor(max_workers=max(1, options.concurrency)) as pool:
                    list(pool.map(follow, pending))
            counts = Counter(o.outcome for o in outcomes)
    finally:
        client.close()
    _write_report(options.report, outcomes)
    summary = ", ".join(f"{counts.get(k, 0)} {k}" for k in
                        ("accepted", "updated", "skipped", "refused", "failed", "ready"))
    print(f"{len(sources)} files: {summary}; report: {options.report}", file=sys.stderr)
    bad = counts.get("refused", 0) + counts.get("failed", 0)
    return (1 if bad else 0), counts
