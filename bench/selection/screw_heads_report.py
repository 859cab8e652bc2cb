"""Issue 24: does the descriptor see a screw's proportions before its head? (a report)

BOSL2's socket-head, button-head and countersunk screws come in the same eight (thread,
length) sizes (``core.evaluation.sources.bosl2_parts``), so each screw has two of another
head and its own size, and seven of its own head and other sizes. If the descriptor saw the
head first, a screw's own-head screws would rank above the other heads of its size. This
script describes the 24 screws (or the kinds ``--heads`` names, eight sizes each: cqparts'
four machine screws share theirs) with the shipped default (``core.pipeline.describe``) and
reports, in plain cosine order, how often a same-size screw of another head ranks above
the median screw of the query's own head, and both groups' ranks: for the whole descriptor
and for each of its blocks alone (``DescriptorSpec.blocks``), to show which blocks see the
head and which the proportions. It chooses nothing.

    .venv/bin/python bench/selection/screw_heads_report.py /work/tuning/bosl2
    .venv/bin/python bench/selection/screw_heads_report.py /work/tuning/cqparts \\
        --heads socket_head_screw button_head_screw countersunk_screw pan_head_screw
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import numpy as np  # noqa: E402

from core.descriptor import DescriptorSpec  # noqa: E402
from core.pipeline import describe  # noqa: E402
from core.settings import EngineSettings  # noqa: E402

HEADS: tuple[str, ...] = ("socket_head_screw", "button_head_screw", "countersunk_screw")
SIZES = 8


def ranks(descriptors: np.ndarray, heads: list[str], sizes: list[int]
          ) -> tuple[list[float], list[float], int, int]:
    """Per query: the median rank of its own head's screws, the mean rank of its size's
    other heads; and how many of the latter rank above the former (of how many)."""
    unit = descriptors / np.linalg.norm(descriptors, axis=1, keepdims=True)
    distances = 1.0 - unit @ unit.T
    np.fill_diagonal(distances, np.inf)
    own_head, own_size, above, pairs = [], [], 0, 0
    for query in range(len(unit)):
        rank = np.empty(len(unit), dtype=int)
        rank[np.argsort(distances[query])] = np.arange(len(unit))
        others = [j for j in range(len(unit)) if j != query]
        same_head = [rank[j] for j in others if heads[j] == heads[query]]
        same_size = [rank[j] for j in others
                     if heads[j] != heads[query] and sizes[j] == sizes[query]]
        median = float(np.median(same_head))
        own_head.append(median)
        own_size.append(float(np.mean(same_size)))
        above += sum(r < median for r in same_size)
        pairs += len(same_size)
    return own_head, own_size, above, pairs


def report(name: str, rows: np.ndarray, heads: list[str], sizes: list[int]) -> None:
    own_head, own_size, above, pairs = ranks(rows, heads, sizes)
    print(f"{name:10s} {above:3d} / {pairs} = {above / pairs:.2f}   own head's median rank "
          f"{np.median(own_head):5.1f}   same size, other head: mean rank {np.mean(own_size):5.1f}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("source", type=Path,
                        help="the source's folder core.evaluation.sources wrote")
    parser.add_argument("--heads", nargs="+", default=list(HEADS),
                        help="the screw kinds, which share their eight sizes")
    args = parser.parse_args(argv)
    spec = DescriptorSpec.from_settings(EngineSettings().descriptor)
    whole, blocks, heads, sizes = [], [], [], []
    for head in args.heads:
        for size in range(SIZES):
            found = describe(args.source / head / f"{head}_{size:02d}.ply")
            whole.append(found.descriptor)
            blocks.append(spec.blocks(found.signature, found.areas, found.eigenvalues,
                                      found.points))
            heads.append(head)
            sizes.append(size)
    print(f"a same-size screw of another head ranks above the median screw of the query's "
          f"own head (of pairs); ranks among the other {len(heads) - 1}:")
    report("whole", np.array(whole, dtype=np.float64), heads, sizes)
    for name in blocks[0]:
        rows = np.array([found[name] for found in blocks], dtype=np.float64)
        if np.all(np.linalg.norm(rows, axis=1) > 0):
            report(name, rows, heads, sizes)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
