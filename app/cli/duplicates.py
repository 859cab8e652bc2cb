"""``shapesearch duplicates``: the duplicate report of one tenant, as CSV or JSON, on stdout."""

from __future__ import annotations

import csv
import json
import sys

from app.db.session import open_sessions
from app.ingest.redescribe import current_version
from app.search.duplicates import DuplicateGroup, find_groups
from app.settings import Settings

__all__ = ["run"]


def run(*, min_score: float, output_format: str, tenant: str,
        descriptor_version: str | None, size_tolerance: float | None = None) -> int:
    """Write the groups at ``min_score`` (CSV: one row per member; JSON: the API's groups)."""
    settings = Settings()
    version = descriptor_version or current_version(settings)
    with open_sessions(settings.resolved_database_url)() as session:
        groups = find_groups(session, tenant, version, min_score,
                             size_tolerance=size_tolerance)
    if output_format == "json":
        _write_json(groups)
    else:
        _write_csv(groups)
    print(f"{len(groups)} group(s) at min_score {min_score} in {version}", file=sys.stderr)
    return 0


def _write_json(groups: list[DuplicateGroup]) -> None:
    report = [
        {
            "size": len(group.members),
            "members": [
                {"id": str(m.id), "external_id": m.external_id, "name": m.name}
                for m in group.members
            ],
            "pairs": [
                {"a": str(group.members[i].id), "b": str(group.members[j].id), "score": s}
                for i, j, s in group.pairs
            ],
        }
        for group in groups
    ]
    json.dump(report, sys.stdout, indent=2)
    sys.stdout.write("\n")


def _write_csv(groups: list[DuplicateGroup]) -> None:
    writer = csv.writer(sys.stdout)
    writer.writerow(["group", "size", "model_id", "external_id", "name", "best_score"])
    for number, group in enumerate(groups, start=1):
        best = [0.0] * len(group.members)
        for i, j, score in group.pairs:
            best[i], best[j] = max(best[i], score), max(best[j], score)
        for member, score in zip(group.members, best, strict=True):
            writer.writerow([number, len(group.members), member.id, member.external_id or "",
                             member.name or "", f"{score:.6f}"])
