"""Does the search service's scan mode reproduce ``scan_hubs_select.py``'s figures?

The study scores its candidates with its own code over the whole catalogue. The service
orders the ``4 k`` nearest models by best entry, taking entries best bound first, with
radii from its index (``app.search.similarity._scan._scan_hub_order``). This puts a source's
saved descriptors (``scan_retrieval``'s, as the study read them) into a SQLite database as
ready models with their views, and asks ``find_similar(mode="scan")`` for every single-view
scan with the scanned model left out (``exclude``: out of the answer and of every radius,
the study's leave-one-out) and ``k`` the whole catalogue, in plain order
(``hub_neighbours`` 0) and with the discount. Printed: mAP and NN of both, to set beside the
study's rows for the source.

And how far the service's pool (the ``4 k`` nearest by best entry, ``rerank_depth``) is from
the whole catalogue's order: for ``k`` 10, the share of queries whose first 10 are the
whole catalogue's first 10 (``core.rank.hubness.scan_hub_keys``) in the same order. Written
before it ran, as shape mode's depth was chosen: the depth is kept if the share is at least
95 % on every source given, else the next factor (8) is measured.

    .venv/bin/python bench/selection/scan_hubs_service_check.py /work/scanhub/bosl2 \\
        /work/scanhub/mcad /work/scanhub/vslot /work/scanhub/madcad /work/scanhub/gearworks

**Result** (2026-11-27, fifteenth session): the study's mAP / NN to the third decimal on all
five; first 10 as the whole catalogue's for 100 % of the queries (MCAD 87 of 88): the
depth stays ``4 k``.

Since the sixteenth session scan mode also re-orders its pool after the first answer
(``core.rank.hubness.scan_ranking``, ``bench/selection/scan_expansion_select.py``): the first-10
column compares the service at ``k`` 10 with ``scan_ranking`` at depth ``rerank_depth(10)``,
the study's order; the mAP column asks the service for the whole catalogue, whose pool is
then the whole catalogue (the study's pool is 40), so it is not the study's figure.
Sixteenth session: first 10 as the study's order for BOSL2 0.958, MCAD 0.852, bd-vslot
0.979, pymadcad 0.925, py-gearworks 0.971 of queries: the pools differ at their edge (plain
distance against key), at equal mAP (``scan_expansion_pool_check.py``); the depth stays.

Since the thirty-eighth session the rest of the pool follows the first answer's shape-mode
order (``core.rank.scan_order``, ``scan_expansion_select.py --round 2``), and the pool is
``reciprocal_depth(k)`` (at least 40) as in shape mode; the service is asked with its
default k-reciprocal re-rank on. Thirty-eighth session (``/work/scanrev``): first 10 as the
study's order for BOSL2 0.808, MCAD 0.648, bd-vslot 0.958, pymadcad 0.517, py-gearworks
0.771 of queries; the emulation in ``scan_expansion_pool_check.py`` gives the same shares
but pymadcad's (0.64: five of its parts have another's descriptor exactly, fourteen pairs
lie within 1e-3, whose float32 ties the service breaks otherwise); per query the service's
first 10 hold as many of the query's kind as the study's, within 0.2 of 10 (pymadcad +0.05,
BOSL2 +0.01, MCAD -0.17).
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import uuid
from pathlib import Path

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from scan_hubs_select import load_catalogue  # noqa: E402

from core.evaluation.metrics import average_precision  # noqa: E402
from core.rank.hubness import HUB_NEIGHBOURS, neighbourhood_radii, scan_hub_keys  # noqa: E402
from core.rank.reciprocal import reciprocal_depth  # noqa: E402
from core.rank.scan_order import scan_ranking  # noqa: E402

KEY = ("default", "check")


def check(folder: Path) -> dict[str, tuple[float, float]]:
    """mAP and NN of the single-view scans of ``folder``'s source, per order, and (key
    ``first10``) the share of queries whose first 10 at ``k`` 10 are the whole catalogue's."""
    from app.db.feed import record_event
    from app.db.migrate import upgrade
    from app.db.models import Model
    from app.db.session import make_engine, make_session_factory
    from app.search.index import ShapeIndex
    from app.search.similarity import find_similar

    catalogue = load_catalogue(folder, "default")
    with tempfile.TemporaryDirectory() as directory:
        engine = make_engine(f"sqlite:///{directory}/check.db")
        upgrade(engine)
        sessions = make_session_factory(engine)
        index_ids = []
        for model in range(len(catalogue.models)):
            rows = catalogue.entries[catalogue.owners == model].astype(np.float32)
            with sessions.begin() as session:
                row = Model(id=uuid.uuid4(), tenant=KEY[0], meta={}, status="ready",
                            file_name="x.stl", file_size=1, file_sha256="0" * 64,
                            file_format="stl", descriptor=rows[0].tobytes(),
                            descriptor_version=KEY[1], view_descriptors=rows[1:].tobytes())
                session.add(row)
                session.flush()
                record_event(session, row.index_id, "ready", KEY[0])
                index_ids.append(row.index_id)
        label_of = dict(zip(index_ids, catalogue.labels, strict=True))
        index = ShapeIndex(sessions, reciprocal=True)  # the service's default order
        index.rebuild()
        scores = {}
        for order, neighbours in (("plain", 0), ("discount", HUB_NEIGHBOURS)):
            index.hub_neighbours = neighbours
            precisions, firsts = [], []
            queries = catalogue.queries["single+sor"]
            for query, model in zip(queries, catalogue.query_models["single+sor"], strict=True):
                own = index_ids[model]
                with engine.connect() as connection:
                    found = find_similar(index, connection, KEY, query, mode="scan",
                                         k=len(index_ids) - 1, exclude=own)
                relevant = np.array([label_of[m.model.index_id] == label_of[own] for m in found])
                if relevant.any():
                    precisions.append(average_precision(relevant))
                    firsts.append(bool(relevant[0]))
            scores[order] = (float(np.mean(precisions)), float(np.mean(firsts)))
        all_keys = scan_hub_keys(queries, catalogue.entries, catalogue.owners,
                                 catalogue.query_models["single+sor"])
        whole = catalogue.entries[~catalogue.is_view][np.argsort(
            catalogue.owners[~catalogue.is_view])].astype(np.float64)
        left_out = catalogue.query_models["single+sor"]
        radii = neighbourhood_radii(whole, HUB_NEIGHBOURS,
                                    exclude=left_out[:, None] == np.arange(len(whole))[None])
        same = []
        for row, (query, model) in enumerate(
                zip(queries, catalogue.query_models["single+sor"], strict=True)):
            keys = all_keys[row].copy()
            keys[model] = np.inf
            # The study's order for 10 results (since the thirty-eighth session the rest
            # after the first answer in that answer's shape-mode order, core.rank.scan_order).
            positions = scan_ranking(keys, whole, reciprocal_depth(10), radii[row])
            expected = [index_ids[m] for m in np.lexsort((np.arange(len(keys)), positions))[:10]]
            with engine.connect() as connection:
                found = find_similar(index, connection, KEY, query, mode="scan", k=10,
                                     exclude=index_ids[model])
            same.append([m.model.index_id for m in found] == expected)
        scores["first10"] = (float(np.mean(same)), float(len(same)))
        engine.dispose()
    return scores


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folders", type=Path, nargs="+")
    args = parser.parse_args(argv)
    print("| source | plain: mAP / NN | service's scan order (k all): mAP / NN | first 10 "
          "as the study's order (k 10) |\n|---|---|---|---|")
    for folder in args.folders:
        scores = check(folder)
        print(f"| {folder.name} | {scores['plain'][0]:.3f} / {scores['plain'][1]:.3f} | "
              f"{scores['discount'][0]:.3f} / {scores['discount'][1]:.3f} | "
              f"{scores['first10'][0]:.3f} of {scores['first10'][1]:.0f} |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
