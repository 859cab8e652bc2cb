"""``python -m core.evaluation.sources OUT [--sources NAME ...] [--seed S]``."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from core.evaluation.sources import DEFAULT_SOURCES, SOURCES, write_sources


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Write the labelled tuning sources.")
    parser.add_argument("out", type=Path)
    parser.add_argument("--sources", nargs="+", default=list(DEFAULT_SOURCES),
                        choices=[*SOURCES, "capod"])
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    counts = write_sources(args.out, args.sources, args.seed)
    print(json.dumps({name: sum(c.values()) for name, c in counts.items()}))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
