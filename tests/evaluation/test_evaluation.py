"""Evaluation harness: scan simulator, dataset walk, eigenpair sharing and caching."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import scipy.linalg
import scipy.sparse as sp

from core.evaluation.dataset import load_dataset, read_cla
from core.evaluation.runner import EigenStore, VariantSolver
from core.evaluation.scans import (
    ScanSettings,
    add_noise_and_outliers,
    hidden_point_removal,
    multi_view_scan,
    random_rotation,
    single_view_scan,
)
from core.io import validate_points


def sphere(n: int = 4000, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    points = rng.normal(size=(n, 3))
    return points / np.linalg.norm(points, axis=1, keepdims=True)


# -- scans ---------------------------------------------------------------------------------


def test_hidden_point_removal_sees_the_near_cap_of_a_sphere() -> None:
    points = sphere()
    viewpoint = np.array([0.0, 0.0, 10.0])
    visible = hidden_point_removal(points, viewpoint)
    # From distance d a unit sphere shows the cap z > 1/d: (1 - 1/d) / 2 = 45 % of its area.
    assert 0.40 < visible.size / len(points) < 0.50
    # Nothing on the far side is seen.
    assert np.all(points[visible, 2] > 0.0)


def test_single_view_scan_sees_part_and_multi_view_sees_more() -> None:
    points = sphere()
    settings = ScanSettings(noise=0.0, outliers=0.0)
    single = single_view_scan(points, np.random.default_rng(1), settings)
    multi = multi_view_scan(points, np.random.default_rng(1), settings)
    assert len(single) < len(points)
    assert len(single) < len(multi) <= len(points)


def test_noise_has_the_asked_standard_deviation() -> None:
    points = sphere(20000)
    diagonal = float(np.linalg.norm(points.max(axis=0) - points.min(axis=0)))
    box = (points.min(axis=0), points.max(axis=0))
    noisy = add_noise_and_outliers(points, np.random.default_rng(2), diagonal, box, 0.005, 0.0)
    assert noisy.shape == points.shape
    # 0.5 % of the diagonal per coordinate, within sampling error (60000 draws).
    assert np.std(noisy - points) == pytest.approx(0.005 * diagonal, rel=0.02)


def test_outliers_make_up_the_asked_share() -> None:
    points = sphere(9900)
    box = (points.min(axis=0), points.max(axis=0))
    scan = add_noise_and_outliers(points, np.random.default_rng(3), 1.0, box, 0.0, 0.01)
    # 9900 inliers + 100 outliers: exactly 1 % of 10000.
    assert len(scan) == 10000
    stray = scan[len(points) :]
    assert len(stray) / len(scan) == pytest.approx(0.01)
    # Outliers lie in the box enlarged by 10 % per side, and mostly off the surface.
    assert np.all(np.abs(stray) <= 1.2 + 1e-9)
    assert np.mean(np.abs(np.linalg.norm(stray, axis=1) - 1.0) > 0.05) > 0.8


def test_scans_are_deterministic_with_a_seed() -> None:
    points = sphere()
    first = single_view_scan(points, np.random.default_rng(7))
    again = single_view_scan(points, np.random.default_rng(7))
    other = single_view_scan(points, np.random.default_rng(8))
    np.testing.assert_array_equal(first, again)
    assert first.shape != other.shape or not np.array_equal(first, other)


def test_random_rotation_is_a_proper_rotation() -> None:
    rotation = random_rotation(np.random.default_rng(4))
    np.testing.assert_allclose(rotation @ rotation.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(rotation) == pytest.approx(1.0)


# -- dataset -------------------------------------------------------------------------------


def test_dataset_drops_byte_identical_files_and_checks_the_cla(tmp_path: Path) -> None:
    for label, name, text in [
        ("Cup", "m1.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"),
        ("Cup", "m2.off", "OFF\n3 1 0\n0 0 0\n2 0 0\n0 1 0\n3 0 1 2\n"),
        ("Cup", "m3.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"),  # = m1
        ("Pan", "m4.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 0 1\n3 0 1 2\n"),
    ]:
        (tmp_path / label).mkdir(exist_ok=True)
        (tmp_path / label / name).write_text(text)
    (tmp_path / "Cup" / "notes.txt.bak").write_text("ignored")
    (tmp_path / "x.cla").write_text("PSB 1\n2 4\n\nCup 0 2\n1\n2\n\nPan 0 2\n3\n4\n")
    assert read_cla(tmp_path / "x.cla") == {"1": "Cup", "2": "Cup", "3": "Pan", "4": "Pan"}
    dataset = load_dataset(tmp_path)
    assert [m.name for m in dataset.models] == ["Cup/m1.off", "Cup/m2.off", "Pan/m4.off"]
    assert dataset.duplicates == [("Cup/m3.off", "Cup/m1.off")]
    assert dataset.cla_mismatches == []


# -- eigenpair sharing ---------------------------------------------------------------------


class DenseSolver:
    """A stand-in for core.eigen.SpectralSolver: exact pairs, bands of 10, fake timings."""

    def __init__(self, stiffness: sp.spmatrix, mass: sp.spmatrix) -> None:
        self.values, self.vectors = scipy.linalg.eigh(stiffness.toarray(), mass.toarray())
        self.eigenvalues_ = self.values[:0]
        self.eigenvectors_ = self.vectors[:, :0]
        self.solver_calls_ = 0
        self.bands_: list[dict[str, float]] = []

    def solve(self, count: int) -> tuple[np.ndarray, np.ndarray]:
        if count > self.eigenvalues_.size:
            self.solver_calls_ += 1
            while self.eigenvalues_.size < count:
                self.bands_.append({"count": 10, "seconds": 1.0})
                size = self.eigenvalues_.size + 10
                self.eigenvalues_, self.eigenvectors_ = self.values[:size], self.vectors[:, :size]
        return self.eigenvalues_[:count], self.eigenvectors_[:, :count]


def path_graph(n: int = 60) -> tuple[sp.csr_matrix, sp.csr_matrix]:
    main = np.full(n, 2.0)
    main[[0, -1]] = 1.0
    stiffness = sp.diags([main, -np.ones(n - 1), -np.ones(n - 1)], [0, 1, -1]).tocsr()
    return stiffness, sp.identity(n, format="csr") / n


def make_store(factory_calls: list[int]) -> EigenStore:
    stiffness, mass = path_graph()

    def factory() -> DenseSolver:
        factory_calls.append(1)
        return DenseSolver(stiffness, mass)

    return EigenStore(np.empty(0), np.empty((60, 0)), mass.diagonal(), [], {}, factory)


def test_variant_views_share_pairs_but_count_their_own_calls() -> None:
    factories: list[int] = []
    store = make_store(factories)
    big = VariantSolver(store)
    values, vectors = big.solve(25)
    assert values.shape == (25,) and vectors.shape == (60, 25)
    assert big.solver_calls_ == 1
    # A second variant asking for less is served from the store, but it still counts the
    # calls its own solver would have made.
    small = VariantSolver(store)
    small.solve(5)
    small.solve(5)  # nothing new: not a call
    small.solve(15)
    assert small.solver_calls_ == 2
    assert len(factories) == 1
    # Seconds: bands of 10 pairs at 1 s each; 15 pairs need two bands, 25 need three.
    assert store.seconds_for(15) == 2.0
    assert store.seconds_for(25) == 3.0


def test_store_round_trips_through_the_cache_and_grows_on_demand(tmp_path: Path) -> None:
    factories: list[int] = []
    store = make_store(factories)
    VariantSolver(store).solve(20)
    store.timings = {"load": 0.5, "laplacian": 0.25, "n_points": 60.0}
    store.save(tmp_path / "pairs.npz")
    loaded = EigenStore.load(tmp_path / "pairs.npz", store.factory)
    np.testing.assert_array_equal(loaded.eigenvalues, store.eigenvalues)
    assert loaded.timings == store.timings
    assert loaded.seconds_for(20) == 2.0
    # Served from the cache: no new solver.
    VariantSolver(loaded).solve(20)
    assert len(factories) == 1 and not loaded.changed
    # Asking for more builds a solver again and marks the store for saving.
    values, _ = VariantSolver(loaded).solve(35)
    assert values.size == 35 and loaded.changed and len(factories) == 2


def test_engine_outlier_filter_drops_stray_points_and_keeps_the_surface() -> None:
    points = sphere(5000)
    box = (points.min(axis=0), points.max(axis=0))
    scan = add_noise_and_outliers(points, np.random.default_rng(5), 2.0, box, 0.0, 0.01)
    kept = validate_points(scan, max_points=len(scan), remove_outliers=True)
    on_surface = np.abs(np.linalg.norm(kept, axis=1) - 1.0) < 0.05
    # Nearly all 5000 surface points survive; at most a handful of the ~50 strays do.
    assert np.count_nonzero(on_surface) > 0.97 * len(points)
    assert np.count_nonzero(~on_surface) <= 10


# -- a finished run is never lost ------------------------------------------------------------


def _tiny_dataset(root: Path) -> Path:
    """Two classes (spheres, tori) of two point clouds each, written as .xyz files."""
    from tests.shapes import sphere_points, torus_points

    for label, make in (("sphere", sphere_points), ("torus", torus_points)):
        (root / label).mkdir(parents=True)
        for seed in (0, 1):
            np.savetxt(root / label / f"m{seed}.xyz", make(600, seed=seed))
    return root


def _tiny_variants() -> dict:
    from core.settings import CutoffSettings, EngineSettings

    return {"default": EngineSettings(max_points=600, cutoff=CutoffSettings(mode="fixed", n=20))}


def test_eval_without_matplotlib_writes_results_and_says_so_in_one_line(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    import json
    import sys

    from core.evaluation.cli import evaluate

    # A None entry in sys.modules makes ``import matplotlib`` raise ImportError.
    for name in [m for m in sys.modules if m == "matplotlib" or m.startswith("matplotlib.")]:
        monkeypatch.delitem(sys.modules, name)
    monkeypatch.setitem(sys.modules, "matplotlib", None)
    dataset = load_dataset(_tiny_dataset(tmp_path / "data"))
    out = tmp_path / "out"
    record = evaluate(dataset, _tiny_variants(), out, use_cache=False)

    saved = json.loads((out / "results.json").read_text())
    assert saved["variants"]["default"]["scores"]["clean"]["nn"] == pytest.approx(
        record["variants"]["default"]["scores"]["clean"]["nn"]
    )
    assert "## Clean models" in (out / "results.md").read_text()
    assert saved["plots"] == [] and not list(out.glob("*.png"))
    err = capsys.readouterr().err
    said = [line for line in err.splitlines() if "matplotlib" in line]
    assert len(said) == 1 and "not installed" in said[0]
    assert "Traceback" not in err


def test_eval_writes_results_before_plotting(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import core.evaluation.cli as evaluation_cli

    def broken_plots(record: dict, out: Path) -> list[str]:
        raise RuntimeError("plotting failed")

    monkeypatch.setattr(evaluation_cli, "plots_from_record", broken_plots)
    dataset = load_dataset(_tiny_dataset(tmp_path / "data"))
    out = tmp_path / "out"
    with pytest.raises(RuntimeError, match="plotting failed"):
        evaluation_cli.evaluate(dataset, _tiny_variants(), out, use_cache=False)
    # The run's numbers survived the failed plot.
    assert "default" in (out / "results.json").read_text()
    assert "| default |" in (out / "results.md").read_text()


@pytest.mark.slow
def test_budget_rows_gather_the_points_variants_of_several_runs(tmp_path: Path) -> None:
    from core.evaluation.budget import budget_rows, budget_table, plot_budget

    def run(points: int, clean_map: float, scan_map: float | None) -> dict:
        def scored(value: float) -> tuple[dict, dict]:
            scores = {"map": value, "nn": value, "top5": value / 2}
            stats = {"n": {"median": 180.0}, "solver_calls_mean": 2.5,
                     "eigensolve_seconds_mean": points / 1000, "ingest_seconds_mean": points / 900}
            return scores, stats

        variant = {"scores": {}, "stats": {}}
        for kind, value in (("clean", clean_map), ("multi+sor", scan_map)):
            if value is not None:
                variant["scores"][kind], variant["stats"][kind] = scored(value)
        return {"dataset": {"models": 45},
                "variants": {f"points-{points}": variant, "default": variant}}

    rows = budget_rows([run(5000, 0.86, 0.58), run(2000, 0.85, 0.70), run(20000, 0.80, None)])
    # Only points-<N> variants, clean rows first, each kind by increasing points.
    assert [(r["query"], r["points"]) for r in rows] == [
        ("clean", 2000), ("clean", 5000), ("clean", 20000),
        ("multi+sor", 2000), ("multi+sor", 5000),
    ]
    assert rows[3]["map"] == 0.70 and rows[2]["ingest_s"] == pytest.approx(20000 / 900)
    table = budget_table(rows)
    assert "| 5000 | multi+sor | 45 | 0.580 | 0.580 | 0.290 |" in table
    plot_budget(rows, tmp_path / "budget.png")
    assert (tmp_path / "budget.png").stat().st_size > 1000


def test_cached_stores_keep_the_points_and_old_caches_get_them_back(tmp_path: Path) -> None:
    from core.evaluation.cli import _solver_factory
    from core.evaluation.runner import describe_sampling, run_variants, sampling_of

    dataset = load_dataset(_tiny_dataset(tmp_path / "data"))
    model = dataset.models[2]  # a torus
    settings = _tiny_variants()["default"]
    sampling = sampling_of(settings, rotation_seed=1)
    cache = tmp_path / "cache"
    fresh = describe_sampling(model, sampling, settings, cache, _solver_factory())
    expected = run_variants(fresh, {"default": settings})["default"].descriptor
    assert fresh.points is not None and fresh.points.shape == (fresh.areas.size, 3)
    path = cache / sampling.cache_name(model.sha256)
    fresh.save(path)
    cached = describe_sampling(model, sampling, settings, cache, _solver_factory())
    np.testing.assert_array_equal(cached.points, fresh.points)
    np.testing.assert_array_equal(run_variants(cached, {"default": settings})["default"].descriptor,
                                  expected)
    # A cache written before the points were kept: the same sampling is drawn again, and
    # the extrinsic blocks, blind to position and scale, give the same vector.
    with np.load(path, allow_pickle=True) as data:
        old = {key: data[key] for key in data.files if key != "points"}
    np.savez(path, **old)
    resumed = describe_sampling(model, sampling, settings, cache, _solver_factory())
    assert resumed.changed and resumed.points.shape == fresh.points.shape
    np.testing.assert_allclose(
        run_variants(resumed, {"default": settings})["default"].descriptor, expected, atol=1e-6
    )


@pytest.mark.slow
def test_eval_scores_the_hub_discount_beside_the_plain_ranking(tmp_path: Path) -> None:
    import json

    from core.evaluation.cli import evaluate

    dataset = load_dataset(_tiny_dataset(tmp_path / "data"))
    plain = evaluate(dataset, _tiny_variants(), tmp_path / "plain", use_cache=False)
    record = evaluate(dataset, _tiny_variants(), tmp_path / "hub", use_cache=False,
                      hub_neighbours=1)
    entry = json.loads((tmp_path / "hub" / "results.json").read_text())["variants"]["default"]
    # The plain scores are untouched; the discounted ones sit beside them.
    assert entry["scores"]["clean"] == pytest.approx(
        plain["variants"]["default"]["scores"]["clean"])
    assert set(entry["hub"]) == {"clean"}
    # Spheres and tori stay apart with the discount too (keys in the wrong order would put
    # the other kind first).
    assert entry["hub"]["clean"]["nn"] == 1.0 and entry["hub"]["clean"]["map"] == 1.0
    assert record["hub_discount"] == {
        "neighbours": 1, "weight": 1.0,
        "reciprocal": {"neighbours": 5, "expansion": 3, "blend": 0.1}}
    report = (tmp_path / "hub" / "results.md").read_text()
    assert "## With a hub discount (CSLS, k 1, weight 1), re-ranked k-reciprocally (k1 5" in report
    assert "| default | clean |" in report
    assert "hub" not in plain["variants"]["default"]
    # The per-kind table: both kinds, found first every time.
    assert entry["per_class"] == {
        kind: {"queries": 2, "nn": 1.0, "map": 1.0, "mistakes": {}} for kind in ("sphere", "torus")}
    assert "## Per kind (variant default, clean queries), worst mAP first" in report
    assert "| sphere | 2 | 1.000 | 1.000 | - | 1.000 / 1.000 |" in report
    assert entry["hub_per_class"]["torus"]["map"] == 1.0
    assert "| sphere | 2 | 1.000 | 1.000 | - |\n" in (tmp_path / "plain" / "results.md").read_text()
    assert "hub discount" not in (tmp_path / "plain" / "results.md").read_text()


def test_eval_refuses_a_hub_discount_it_cannot_compute(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from app.cli import build_parser

    def run(data: Path, neighbours: str) -> int:
        args = build_parser().parse_args(["eval", str(data), "--out", str(tmp_path / "o"),
                                          "--hub-discount", neighbours])
        return int(args.handler(args))

    data = _tiny_dataset(tmp_path / "data")
    assert run(data, "-1") == 2
    for file in (data / "torus").iterdir():  # two models left: no radius without the query
        file.unlink()
    assert run(data, "10") == 2
    err = capsys.readouterr().err
    assert err.count("--hub-discount needs K >= 1 and at least 3 models") == 2
    assert "Traceback" not in err and not (tmp_path / "o").exists()


def test_eval_scores_the_service_s_order_unless_told_otherwise() -> None:
    from app.cli import build_parser
    from core.evaluation.cli import hub_neighbours_for
    from core.rank.hubness import HUB_NEIGHBOURS

    default = build_parser().parse_args(["eval", "data"]).hub_discount
    assert hub_neighbours_for(default, 245) == HUB_NEIGHBOURS == 10
    assert hub_neighbours_for(default, 2) == 0  # too few models for any neighbourhood
    assert hub_neighbours_for(0, 245) == 0 and hub_neighbours_for(5, 245) == 5


def test_eval_ranks_scans_by_the_hub_discount_alone_not_as_their_own_model() -> None:
    # Scans are named after their models. The k-reciprocal re-rank compares a query's
    # neighbourhood with the catalogue's, which only clean queries (the catalogue itself)
    # have: re-ranking a scan as if it were its clean model would lend it that model's
    # neighbourhood. Scans of pure noise must score what the hub discount alone gives them.
    from core.cutoff import CutoffRecord
    from core.evaluation.cli import score_variant
    from core.evaluation.metrics import ranked_relevance, score_rankings
    from core.evaluation.runner import ModelResult
    from core.rank.hubness import hub_discounted_keys

    rng = np.random.default_rng(3)
    record = CutoffRecord(mode="fixed", n=10, solver_calls=1, predicted=[])
    centres = rng.normal(size=(6, 32))
    names = [f"m{i:02d}" for i in range(30)]
    labels = {name: f"class{i // 5}" for i, name in enumerate(names)}

    def results(vectors: np.ndarray) -> dict[str, ModelResult]:
        unit = vectors / np.linalg.norm(vectors, axis=1, keepdims=True)
        return {name: ModelResult(record, 0.0, 0.0, row, 100)
                for name, row in zip(names, unit, strict=True)}

    clean = results(np.repeat(centres, 5, axis=0) + 0.3 * rng.normal(size=(30, 32)))
    noise = results(rng.normal(size=(30, 32)))
    base = np.array([clean[name].descriptor for name in names])
    own = np.eye(30, dtype=bool)
    keys = hub_discounted_keys(np.array([noise[n].descriptor for n in names]), base, 3,
                               exclude=own)
    label_list = [labels[n] for n in names]
    alone = score_rankings(ranked_relevance(keys, label_list, label_list, own))

    scans = score_variant(clean, noise, labels, hub_neighbours=3)[0]
    assert scans == alone
    assert scans["map"] < 0.5  # noise finds its class by chance only
    assert score_variant(clean, clean, labels, hub_neighbours=3, clean=True)[0]["map"] > 0.9


def test_eval_scores_scans_in_scan_mode_where_only_the_views_meet_them() -> None:
    """A scan that sees what every model of its class shows from one side (its views), while
    another class's whole descriptors lie nearer it than its own class's: shape mode (whole
    models) ranks the other class first, scan mode (whole models and their views) its own."""
    from core.cutoff import CutoffRecord
    from core.evaluation.cli import score_scan_mode, score_variant
    from core.evaluation.runner import ModelResult

    rng = np.random.default_rng(5)
    record = CutoffRecord(mode="fixed", n=10, solver_calls=1, predicted=[])
    d = 24
    basis = np.eye(d)
    names = [f"{kind}{i}" for kind in ("a", "b") for i in range(4)]
    labels = {name: name[0] for name in names}

    def results(rows: dict[str, np.ndarray]) -> dict[str, ModelResult]:
        return {name: ModelResult(record, 0.0, 0.0, row / np.linalg.norm(row), 100)
                for name, row in rows.items()}

    side = basis[0]  # what a scan of class a sees
    whole = {n: (basis[1] + 0.9 * side if n[0] == "b" else basis[2]) + 0.05 * rng.normal(size=d)
             for n in names}
    view = {n: (side + 0.1 * basis[3] if n[0] == "a" else basis[4]) + 0.05 * rng.normal(size=d)
            for n in names}
    scan = {n: side + 0.05 * rng.normal(size=d) for n in names if n[0] == "a"}
    clean, views, scans = results(whole), results(view), results(scan)
    shape = score_variant(clean, scans, labels)[0]
    scan_mode = score_scan_mode(clean, [views], scans, labels)
    plain_scan_mode = score_scan_mode(clean, [views], scans, labels, discounted=False)
    assert shape["nn"] == 0.0
    assert scan_mode["nn"] == 1.0 and scan_mode["map"] == 1.0
    assert plain_scan_mode["map"] == 1.0


@pytest.mark.slow
def test_eval_writes_a_scan_mode_table_when_asked(tmp_path: Path) -> None:
    import json

    from core.evaluation.cli import evaluate

    dataset = load_dataset(_tiny_dataset(tmp_path / "data"))
    record = evaluate(dataset, _tiny_variants(), tmp_path / "out", use_cache=False,
                      scans=("multi",), scan_variants=("default",), scan_views=2)
    entry = json.loads((tmp_path / "out" / "results.json").read_text())["variants"]["default"]
    assert record["scan_mode"] == {"views": 2, "discounted": False}
    assert set(entry["scan_mode"]) == {"multi"} and 0.0 <= entry["scan_mode"]["multi"]["map"] <= 1
    report = (tmp_path / "out" / "results.md").read_text()
    assert "## Scans in scan mode (2 virtual views per model)" in report
    assert "| default | multi |" in report
    plain = evaluate(dataset, _tiny_variants(), tmp_path / "plain", use_cache=False,
                     scans=("multi",), scan_variants=("default",))
    assert "scan_mode" not in plain and "scan mode" not in (
        tmp_path / "plain" / "results.md").read_text()
