"""``shapesearch duplicates``: compute and store a tenant's duplicates report, and write it
as CSV or JSON on stdout.

The same computation and storage as a ``POST /v1/duplicates`` job
(``app.search.duplicates``, ``app.search.duplicate_reports``), run in this process: it needs
no worker, and the stored report is what ``GET /v1/duplicates`` pages afterwards.
"""

from __future__ import annotations

import csv
import json
import sys

from sqlalchemy.orm import Session

from app.db.session import open_sessions
from app.ingest.redescribe import current_version
from app.search.duplicate_reports import member_names, store_report
from app.search.duplicates import ComputedReport, DuplicatesQuery, compute_report
from app.settings import Settings

__all__ = ["run"]

# One group as written: its members as (id, external_id, name) and its edges (i, j, score).
_Written = tuple[list[tuple[str, str | None, str | None]], list[tuple[int, int, float]]]


def run(*, min_score: float, output_format: str, tenant: str,
        descriptor_version: str | None, size_tolerance: float | None = None) -> int:
    """Compute, store and write the report (CSV: one row per member; JSON: the API's
    groups)."""
    settings = Settings()
    query = DuplicatesQuery(
        descriptor_version=descriptor_version or current_version(settings),
        min_score=min_score,
        size_tolerance=size_tolerance,
    )
    sessions = open_sessions(settings.resolved_database_url)
    report = compute_report(sessions, tenant, query, **settings.index_options)
    with sessions.begin() as session:
        report_id = store_report(session, tenant, report, job_id=None)
        groups = _named(session, tenant, report)
    if output_format == "json":
        _write_json(groups)
    else:
        _write_csv(groups)
    print(
        f"{len(groups)} group(s) among {report.models} models at min_score {min_score} in "
        f"{query.descriptor_version} ({report.seconds:.1f}s; stored as report {report_id})",
        file=sys.stderr,
    )
    return 0


def _named(session: Session, tenant: str, report: ComputedReport) -> list[_Written]:
    ids = [str(member) for group in report.groups for member in group.members]
    names = member_names(session, tenant, ids)
    return [
        (
            [(str(m), *names.get(str(m), (None, None))) for m in group.members],
            group.pairs,
        )
        for group in report.groups
    ]


def _write_json(groups: list[_Written]) -> None:
    report = [
        {
            "number": number,
            "size": len(members),
            "members": [
                {"id": model_id, "external_id": external_id, "name": name}
                for model_id, external_id, name in members
            ],
            "pairs": [
                {"a": members[i][0], "b": members[j][0], "score": score}
                for i, j, score in pairs
            ],
        }
        for number, (members, pairs) in enumerate(groups, start=1)
    ]
    json.dump(report, sys.stdout, indent=2)
    sys.stdout.write("\n")


def _write_csv(groups: list[_Written]) -> None:
    writer = csv.writer(sys.stdout)
    writer.writerow(["group", "size", "model_id", "external_id", "name", "best_score"])
    for number, (members, pairs) in enumerate(groups, start=1):
        best = [0.0] * len(members)
        for i, j, score in pairs:
            best[i], best[j] = max(best[i], score), max(best[j], score)
        for (model_id, external_id, name), score in zip(members, best, strict=True):
            writer.writerow([number, len(members), model_id, external_id or "", name or "",
                             f"{score:.6f}"])
