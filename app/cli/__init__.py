"""The ``shapesearch`` command line.

Each sub-command imports its module lazily so that ``shapesearch describe`` does not pay
for the web stack, and ``serve`` does not pay for plotting.

    shapesearch describe FILE [--cutoff adaptive|fixed:N] [--json]
    shapesearch serve   [--host H] [--port P] [--no-worker]
    shapesearch worker  [--concurrency N] [--metrics-port P]
    shapesearch keys create --tenant NAME | list | revoke PREFIX
    shapesearch redescribe [--from-version V | --all] [--wait]
    shapesearch duplicates [--min-score 0.98] [--size-tolerance T] [--format csv|json] [--tenant T]
    shapesearch backup DEST
    shapesearch index rebuild|sync|status
    shapesearch --version
    shapesearch compare A B [--scale] [--tolerance T] [--url URL] [--key KEY] [--json]
    shapesearch import PATH [--url URL] [--key KEY] [--external-id path|stem] [--metadata F]
                            [--assembly split|whole]
                       [--units mm|cm|m|in]
                       [--concurrency N] [--wait] [--report CSV] [--retries N]
                       [--max-file-bytes B]
    shapesearch eval DATASET_DIR [--variants ...] [--out DIR]
    shapesearch eval-parts OUT_DIR [--per-family N] [--seed S]
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Sequence
from pathlib import Path

__all__ = ["main"]


def _describe(args: argparse.Namespace) -> int:
    from core.describe_cli import run

    return run(args)


def _serve(args: argparse.Namespace) -> int:
    from app.startup import startup_ok

    if not startup_ok():  # before prometheus-client is imported (its directory is checked)
        return 2
    from app.server import serve

    return serve(host=args.host, port=args.port, embedded_worker=not args.no_worker)


def _worker(args: argparse.Namespace) -> int:
    from app.startup import startup_ok

    if not startup_ok():  # before prometheus-client is imported (its directory is checked)
        return 2
    from app.jobs.worker import run_workers

    return run_workers(concurrency=args.concurrency, metrics_port=args.metrics_port)


def _keys(args: argparse.Namespace) -> int:
    from app.cli import keys

    return keys.create(tenant=args.tenant)


def _keys_list(args: argparse.Namespace) -> int:
    from app.cli import keys

    return keys.list_all()


def _keys_revoke(args: argparse.Namespace) -> int:
    from app.cli import keys

    return keys.revoke(args.prefix)


def _redescribe(args: argparse.Namespace) -> int:
    from app.cli import redescribe

    return redescribe.run(from_version=args.from_version, everything=args.all, wait=args.wait)


def _duplicates(args: argparse.Namespace) -> int:
    from app.cli import duplicates

    return duplicates.run(min_score=args.min_score, output_format=args.format,
                          tenant=args.tenant, descriptor_version=args.descriptor_version,
                          size_tolerance=args.size_tolerance)


def _index(args: argparse.Namespace) -> int:
    from app.cli import index

    return index.run(args.action)


def _backup(args: argparse.Namespace) -> int:
    from app.cli import backup

    return backup.run(Path(args.destination))


def _compare(args: argparse.Namespace) -> int:
    from app.cli import compare

    return compare.run(args.a, args.b, url=args.url, key=args.key, scale=args.scale,
                       tolerance=args.tolerance, as_json=args.json)


def _import(args: argparse.Namespace) -> int:
    import tarfile
    import zipfile
    from pathlib import Path

    import httpx

    from app.cli.importer import DEFAULT_MAX_FILE_BYTES, ImportOptions, run_import

    if not args.url:
        print("error: give the service's URL: --url or SHAPESEARCH_URL", file=sys.stderr)
        return 2
    options = ImportOptions(
        url=args.url, key=args.key, external_id=args.external_id,
        metadata=Path(args.metadata) if args.metadata else None,
        concurrency=args.concurrency, wait=args.wait, report=Path(args.report),
        retries=args.retries, units=args.units, assembly=args.assembly,
        max_file_bytes=args.max_file_bytes or DEFAULT_MAX_FILE_BYTES,
    )
    try:
        code, _counts = run_import(Path(args.path), options)
    except (OSError, ValueError, httpx.HTTPError, tarfile.TarError,
            zipfile.BadZipFile) as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    return code


def _eval(args: argparse.Namespace) -> int:
    from core.evaluation.cli import run

    return run(args)


def _eval_parts(args: argparse.Namespace) -> int:
    from core.evaluation.parts_generator import main

    return main([args.out, "--per-family", str(args.per_family), "--seed", str(args.seed)])


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("shapesearch")
    except PackageNotFoundError:  # run from a source tree that was never installed
        return "unknown"


def _port(text: str) -> int:
    """A TCP port number, 1-65535 (argparse refuses anything else with a clear message)."""
    try:
        port = int(text)
    except ValueError:
        port = 0
    if not 1 <= port <= 65535:
        raise argparse.ArgumentTypeError(f"{text!r} is not a port number (1-65535)")
    return port


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="shapesearch", description=__doc__.splitlines()[0])
    parser.add_argument("--version", action="version", version=f"shapesearch {_version()}")
    commands = parser.add_subparsers(dest="command", required=True)

    describe = commands.add_parser("describe", help="describe one shape file and print the result")
    describe.add_argument("file")
    describe.add_argument("--cutoff", default="adaptive", help="adaptive or fixed:N")
    describe.add_argument("--laplacian", choices=("robust", "spcl"), default=None)
    describe.add_argument("--max-points", type=int, default=None)
    describe.add_argument("--json", action="store_true", help="print JSON instead of text")
    describe.set_defaults(handler=_describe)

    serve = commands.add_parser("serve", help="run the HTTP API")
    serve.add_argument("--host", default=None, help="default: SHAPESEARCH_HOST")
    serve.add_argument("--port", type=int, default=None, help="default: SHAPESEARCH_PORT")
    serve.add_argument("--no-worker", action="store_true", help="do not run a worker in-process")
    serve.set_defaults(handler=_serve)

    worker = commands.add_parser("worker", help="run worker processes that describe uploads")
    worker.add_argument(
        "--concurrency", type=int, default=None,
        help="default: SHAPESEARCH_WORKERS, or one per core",
    )
    worker.add_argument(
        "--metrics-port", type=_port, default=None,
        help="serve the Prometheus metrics of all the worker processes at "
        "http://SHAPESEARCH_HOST:P/metrics (default: SHAPESEARCH_WORKER_METRICS_PORT, or none)",
    )
    worker.set_defaults(handler=_worker)

    keys = commands.add_parser("keys", help="manage API keys")
    key_commands = keys.add_subparsers(dest="keys_command", required=True)
    create = key_commands.add_parser("create", help="create an API key for a tenant")
    create.add_argument("--tenant", required=True)
    create.set_defaults(handler=_keys)
    key_commands.add_parser("list", help="list keys: prefix, tenant, created").set_defaults(
        handler=_keys_list
    )
    revoke = key_commands.add_parser("revoke", help="delete the key with this prefix")
    revoke.add_argument("prefix", help="ss_ + 12 hex digits, as `keys list` shows")
    revoke.set_defaults(handler=_keys_revoke)

    redescribe = commands.add_parser(
        "redescribe", help="queue re-describe jobs (default: models not at the current version)"
    )
    which = redescribe.add_mutually_exclusive_group()
    which.add_argument("--from-version", default=None, help="models with this descriptor_version")
    which.add_argument("--all", action="store_true", help="every model")
    redescribe.add_argument("--wait", action="store_true", help="show progress until done")
    redescribe.set_defaults(handler=_redescribe)

    duplicates = commands.add_parser(
        "duplicates", help="compute and store the duplicates report (groups of near-identical "
        "parts), and print it"
    )
    duplicates.add_argument("--min-score", type=float, default=0.98)
    duplicates.add_argument("--format", choices=("csv", "json"), default="csv")
    duplicates.add_argument("--tenant", default="default")
    duplicates.add_argument("--size-tolerance", type=float, default=None,
                            help="same size too: every extent within this relative tolerance")
    duplicates.add_argument("--descriptor-version", default=None,
                            help="default: the version of the current engine settings")
    duplicates.set_defaults(handler=_duplicates)

    backup = commands.add_parser(
        "backup", help="copy the database (SQLite, or pg_dump's archive of PostgreSQL), "
        "consistently, while the service runs"
    )
    backup.add_argument("destination", help="a new file, or a directory for a time-stamped one")
    backup.set_defaults(handler=_backup)

    index = commands.add_parser(
        "index", help="the search index's Milvus collections (SHAPESEARCH_INDEX_BACKEND=milvus): "
        "rebuild them from the database, sync them with its change feed, or show their status")
    index.add_argument("action", choices=["rebuild", "sync", "status"])
    index.set_defaults(handler=_index)

    comparer = commands.add_parser(
        "compare", help="why two parts match: B placed on A and their deviations (files are "
        "read here, model ids asked of a running service)")
    comparer.add_argument("a", help="a shape file, or a model id (with --url)")
    comparer.add_argument("b", help="a shape file, or a model id (with --url)")
    comparer.add_argument("--scale", action="store_true",
                          help="also find a uniform scale (B in other units or another size)")
    comparer.add_argument("--tolerance", type=float, default=None,
                          help="distance within which a point counts as matched, in A's "
                          "units (default: 1 %% of the larger bounding-box diagonal)")
    comparer.add_argument("--url", default=os.environ.get("SHAPESEARCH_URL"),
                          help="the service, for model ids (default: SHAPESEARCH_URL)")
    comparer.add_argument("--key", "--api-key", dest="key",
                          default=os.environ.get("SHAPESEARCH_API_KEY"),
                          help="API key (Bearer; default: SHAPESEARCH_API_KEY)")
    comparer.add_argument("--json", action="store_true", help="print JSON instead of text")
    comparer.set_defaults(handler=_compare)

    importer = commands.add_parser("import", help="upload a folder, .zip or .tar of parts")
    importer.add_argument("path")
    importer.add_argument("--url", default=os.environ.get("SHAPESEARCH_URL"),
                          help="the service, e.g. http://127.0.0.1:8000 (default: "
                          "SHAPESEARCH_URL)")
    importer.add_argument("--key", default=os.environ.get("SHAPESEARCH_API_KEY"),
                          help="API key (Bearer; default: SHAPESEARCH_API_KEY, which keeps it "
                          "out of ps and the shell history)")
    importer.add_argument("--external-id", choices=("path", "stem"), default="path",
                          help="external id: the relative path (default) or the file stem")
    importer.add_argument("--metadata", default=None, help="sidecar .csv or .json of metadata")
    importer.add_argument("--units", choices=("mm", "cm", "m", "in"), default=None,
                          help="units of the files' coordinates (sizes compare in mm)")
    importer.add_argument("--assembly", choices=("split", "whole"), default=None,
                          help="split: each assembly (GLB, glTF, 3MF, OBJ, STEP, IGES) also "
                          "becomes a model per distinct part; whole: one model a file; "
                          "default: the service's SHAPESEARCH_ASSEMBLY_DEFAULT")
    importer.add_argument("--concurrency", type=int, default=4)
    importer.add_argument("--wait", action="store_true", help="wait until described")
    importer.add_argument("--report", default="import-report.csv", help="CSV of every file")
    importer.add_argument("--retries", type=int, default=5,
                          help="retries of a request on 429/502/503/504 or a connection error "
                          "(jittered backoff, or the service's Retry-After)")
    importer.add_argument("--max-file-bytes", type=int, default=None,
                          help="the service's SHAPESEARCH_MAX_UPLOAD_BYTES: larger files are "
                          "refused without being read (default: 64 MiB, the service's default)")
    importer.set_defaults(handler=_import)

    evaluate = commands.add_parser("eval", help="score retrieval on a labelled CLASS/MODEL dataset")
    evaluate.add_argument("dataset")
    evaluate.add_argument("--variants", nargs="*", default=None)
    evaluate.add_argument("--out", default="eval-out")
    evaluate.add_argument("--limit-per-class", type=int, default=None)
    evaluate.add_argument("--model-list", type=Path, default=None,
                          help="file of CLASS/FILE names (one a line): score only these models")
    evaluate.add_argument(
        "--scans", nargs="*", default=(),
        choices=("single", "multi", "single+sor", "multi+sor", "turntable", "kinect-view",
                 "turntable+sor", "kinect-view+sor"),
        help="also query simulated scans (single view, three views, 18-view depth-sensor "
        "turntable, one sensor view; +sor: with an outlier filter before the engine) against "
        "the clean models",
    )
    evaluate.add_argument("--scan-variants", nargs="*", default=None,
                          help="variants scored on scans (default: baseline, default, fixed)")
    evaluate.add_argument(
        "--scan-views", type=int, default=0, metavar="N",
        help="also score the scans in the service's scan mode: every model described whole "
        "and as N virtual views (the service's default is 3; 0: shape mode only)",
    )
    evaluate.add_argument("--resampling", nargs="*", type=int, default=(),
                          help="point counts of the resampling study, e.g. 5000 10000 20000")
    evaluate.add_argument("--resampling-per-class", type=int, default=4,
                          help="models per class in the resampling study (seeded subset)")
    evaluate.add_argument("--timing-models", type=int, default=0,
                          help="models on which each cutoff is also timed with its own solver")
    evaluate.add_argument("--no-cache", action="store_true", help="do not read or write OUT/cache")
    evaluate.add_argument(
        "--hub-discount", type=int, default=None, metavar="K",
        help="also score every ranking as the search service orders shape-mode answers: "
        "the hub discount (CSLS over each candidate's K nearest; default: the service's "
        "SHAPESEARCH_SEARCH_HUB_NEIGHBOURS default, 10, when the set holds 3 models or more), "
        "re-ranked k-reciprocally over the whole set for clean queries (the discount's first "
        "answer kept first); 0: plain distance order only",
    )
    evaluate.set_defaults(handler=_eval)

    parts = commands.add_parser(
        "eval-parts", help="generate the labelled engineering-parts dev set (tune/ and test/)"
    )
    parts.add_argument("out")
    parts.add_argument("--per-family", type=int, default=20)
    parts.add_argument("--seed", type=int, default=0)
    parts.set_defaults(handler=_eval_parts)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    return int(args.handler(args) or 0)

