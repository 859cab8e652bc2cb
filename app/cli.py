"""The ``shapesearch`` command line.

Each sub-command imports its module lazily so that ``shapesearch describe`` does not pay
for the web stack, and ``serve`` does not pay for plotting.

    shapesearch describe FILE [--cutoff adaptive|fixed:N] [--json]
    shapesearch serve   [--host H] [--port P] [--no-worker]
    shapesearch worker  [--concurrency N]
    shapesearch keys create --tenant NAME
    shapesearch eval DATASET_DIR [--variants ...] [--out DIR]
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

__all__ = ["main"]


def _describe(args: argparse.Namespace) -> int:
    from core.describe_cli import run

    return run(args)


def _serve(args: argparse.Namespace) -> int:
    from app.server import serve

    return serve(host=args.host, port=args.port, embedded_worker=not args.no_worker)


def _worker(args: argparse.Namespace) -> int:
    from app.worker import run_workers

    return run_workers(concurrency=args.concurrency)


def _keys(args: argparse.Namespace) -> int:
    from app.keys import create_key_command

    return create_key_command(tenant=args.tenant)


def _eval(args: argparse.Namespace) -> int:
    from core.evaluation.cli import run

    return run(args)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="shapesearch", description=__doc__.splitlines()[0])
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
    worker.set_defaults(handler=_worker)

    keys = commands.add_parser("keys", help="manage API keys")
    key_commands = keys.add_subparsers(dest="keys_command", required=True)
    create = key_commands.add_parser("create", help="create an API key for a tenant")
    create.add_argument("--tenant", required=True)
    create.set_defaults(handler=_keys)

    evaluate = commands.add_parser("eval", help="score retrieval on a labelled CLASS/MODEL dataset")
    evaluate.add_argument("dataset")
    evaluate.add_argument("--variants", nargs="*", default=None)
    evaluate.add_argument("--out", default="eval-out")
    evaluate.add_argument("--limit-per-class", type=int, default=None)
    evaluate.add_argument("--model-list", type=Path, default=None,
                          help="file of CLASS/FILE names (one a line): score only these models")
    evaluate.add_argument(
        "--scans", nargs="*", choices=("single", "multi", "single+sor", "multi+sor"), default=(),
        help="also query simulated scans (single view, three views; +sor: with an outlier "
        "filter before the engine) against the clean models",
    )
    evaluate.add_argument("--scan-variants", nargs="*", default=None,
                          help="variants scored on scans (default: baseline, default, fixed)")
    evaluate.add_argument("--resampling", nargs="*", type=int, default=(),
                          help="point counts of the resampling study, e.g. 5000 10000 20000")
    evaluate.add_argument("--resampling-per-class", type=int, default=4,
                          help="models per class in the resampling study (seeded subset)")
    evaluate.add_argument("--timing-models", type=int, default=0,
                          help="models on which each cutoff is also timed with its own solver")
    evaluate.add_argument("--no-cache", action="store_true", help="do not read or write OUT/cache")
    evaluate.set_defaults(handler=_eval)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    return int(args.handler(args) or 0)


if __name__ == "__main__":
    sys.exit(main())
