"""The selection rule of research/ (``research.rule``) on tables made in code."""

from __future__ import annotations

import numpy as np

from research.rule import TIE, bootstrap, catalogue_holds, choose, loso, scores, service_order


def _table(maps: dict[str, dict[str, float]]) -> dict[str, dict[str, dict[str, float]]]:
    return {c: {s: {"map": v, "nn": v} for s, v in per.items()} for c, per in maps.items()}


def test_the_choice_goes_to_the_earlier_candidate_within_the_tie() -> None:
    table = _table({"reference": {"a": 0.80, "b": 0.80}, "new": {"a": 0.80 + TIE, "b": 0.80}})
    assert choose(table, ["reference", "new"], ["a", "b"]) == "reference"
    table = _table({"reference": {"a": 0.80, "b": 0.80}, "new": {"a": 0.90, "b": 0.80}})
    assert choose(table, ["reference", "new"], ["a", "b"]) == "new"


def test_leave_one_source_out_chooses_without_the_source() -> None:
    # "new" wins only through source a: chosen without a, it is never scored on a.
    table = _table({"reference": {"a": 0.5, "b": 0.8, "c": 0.8},
                    "new": {"a": 0.9, "b": 0.79, "c": 0.79}})
    assert loso(table, ["reference", "new"], ["a", "b", "c"]) == {
        "a": "reference", "b": "new", "c": "new"}


def test_the_paired_bootstrap_is_zero_for_the_same_queries_and_brackets_a_shift() -> None:
    queries = {"a": np.linspace(0, 1, 50), "b": np.linspace(0.2, 0.9, 30)}
    assert bootstrap(queries, queries, ["a", "b"]) == (0.0, 0.0, 0.0)
    shifted = {s: v + 0.01 for s, v in queries.items()}
    point, low, high = bootstrap(shifted, queries, ["a", "b"])
    assert np.isclose(point, 0.01) and low <= point <= high


def test_test_two_allows_the_nn_slack_and_no_map_loss() -> None:
    reference = {"map": 0.70, "nn": 0.90}
    assert catalogue_holds({"map": 0.70, "nn": 0.895}, reference)
    assert not catalogue_holds({"map": 0.699, "nn": 0.95}, reference)
    assert not catalogue_holds({"map": 0.80, "nn": 0.88}, reference)


def test_two_clear_kinds_score_perfectly_in_the_service_order() -> None:
    rng = np.random.default_rng(0)
    centres = np.eye(8)[:2]
    rows = np.vstack([centres[k] + 0.05 * rng.normal(size=8) for k in (0, 1) for _ in range(6)])
    rows /= np.linalg.norm(rows, axis=1, keepdims=True)
    keys = service_order(rows)
    assert keys.shape == (12, 12)
    result, per_query = scores(keys, ["x"] * 6 + ["y"] * 6)
    assert result["map"] == 1.0 and result["nn"] == 1.0 and per_query.shape == (12,)
