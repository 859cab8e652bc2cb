"""Retrieval metrics on tiny hand-made rankings, with the expected values worked out by hand."""

from __future__ import annotations

import math

import numpy as np
import pytest

from core.evaluation.metrics import (
    average_precision,
    dcg,
    first_tier,
    nearest_neighbour,
    pairwise_distances,
    per_class_scores,
    precision_recall_curve,
    ranked_relevance,
    score_rankings,
    second_tier,
    top_k_hit_rate,
)

# A ranking of 6 results, relevant at ranks 1, 3 and 6 (C = 3 relevant models).
RANKING = np.array([1, 0, 1, 0, 0, 1], dtype=bool)


def test_nearest_neighbour() -> None:
    # Rank 1 is relevant.
    assert nearest_neighbour(RANKING) == 1.0
    assert nearest_neighbour(~RANKING) == 0.0


def test_first_and_second_tier() -> None:
    # FT: first C = 3 results [1, 0, 1] hold 2 of the 3 relevant -> 2/3.
    assert first_tier(RANKING) == pytest.approx(2 / 3)
    # ST: first 2C = 6 results hold all 3 -> 1.
    assert second_tier(RANKING) == pytest.approx(1.0)
    # [0, 1, 1, 0]: C = 2, FT = 1/2 (one in the first two), ST = 2/2 (both in the first four).
    ranking = np.array([0, 1, 1, 0], dtype=bool)
    assert first_tier(ranking) == pytest.approx(0.5)
    assert second_tier(ranking) == pytest.approx(1.0)


def test_dcg_follows_the_psb_convention() -> None:
    # Gains at ranks 1, 3, 6; rank 1 undiscounted, rank i >= 2 divided by log2(i):
    #   DCG   = 1 + 1/log2(3) + 1/log2(6) = 1 + 0.63093 + 0.38685 = 2.01778
    #   ideal = 1 + 1/log2(2) + 1/log2(3) = 1 + 1       + 0.63093 = 2.63093
    #   nDCG  = 2.01778 / 2.63093 = 0.76695
    expected = (1 + 1 / math.log2(3) + 1 / math.log2(6)) / (1 + 1 + 1 / math.log2(3))
    assert dcg(RANKING) == pytest.approx(expected)
    assert dcg(RANKING) == pytest.approx(0.76695, abs=1e-5)
    # A perfect ranking scores 1, whatever follows.
    assert dcg(np.array([1, 1, 0, 0], dtype=bool)) == pytest.approx(1.0)


def test_average_precision() -> None:
    # Precision at the relevant ranks: 1/1, 2/3, 3/6 -> mean (1 + 0.6667 + 0.5) / 3 = 0.72222.
    assert average_precision(RANKING) == pytest.approx((1 + 2 / 3 + 1 / 2) / 3)
    # One relevant model at rank 4: AP = 1/4.
    assert average_precision(np.array([0, 0, 0, 1], dtype=bool)) == pytest.approx(0.25)


def test_top_5_hit_rate() -> None:
    # First five results [1, 0, 1, 0, 0]: 2 of 5 relevant -> 0.4.
    assert top_k_hit_rate(RANKING, 5) == pytest.approx(0.4)
    # A ranking shorter than k averages over what there is: [1, 0] -> 0.5.
    assert top_k_hit_rate(np.array([1, 0], dtype=bool), 5) == pytest.approx(0.5)


def test_precision_recall_curve_is_interpolated() -> None:
    # Recall 1/3 at precision 1, 2/3 at precision 2/3, 1 at precision 1/2. Interpolated
    # precision at recall r is the best precision at any recall >= r:
    #   r = 0.2 -> 1,  r = 0.5 -> max(2/3, 1/2) = 2/3,  r = 1.0 -> 1/2.
    recall, precision = precision_recall_curve(RANKING, np.array([0.2, 0.5, 1.0]))
    np.testing.assert_allclose(precision, [1.0, 2 / 3, 0.5])
    np.testing.assert_allclose(recall, [0.2, 0.5, 1.0])


def test_ranked_relevance_excludes_self_and_breaks_ties_by_index() -> None:
    # Four models, labels a a b b. Symmetric distances:
    #   d01 = 1, d02 = 0.5, d03 = 2, d12 = 3, d13 = 0.2, d23 = 1.5
    distances = np.array(
        [
            [0.0, 1.0, 0.5, 2.0],
            [1.0, 0.0, 3.0, 0.2],
            [0.5, 3.0, 0.0, 1.5],
            [2.0, 0.2, 1.5, 0.0],
        ]
    )
    labels = ["a", "a", "b", "b"]
    relevance = ranked_relevance(distances, labels, labels, exclude=np.eye(4, dtype=bool))
    # Query 0 ranks 2 (b), 1 (a), 3 (b); query 1 ranks 3 (b), 0 (a), 2 (b);
    # query 2 ranks 0 (a), 3 (b), 1 (a); query 3 ranks 1 (a), 2 (b), 0 (a).
    for row in relevance:
        np.testing.assert_array_equal(row, [False, True, False])
    # Every query: C = 1, NN 0, FT 0, ST 1, DCG 1 (rank 2 is undiscounted), AP 1/2, top-5 1/3.
    scores = score_rankings(relevance)
    assert scores == pytest.approx(
        {"nn": 0.0, "ft": 0.0, "st": 1.0, "dcg": 1.0, "map": 0.5, "top5": 1 / 3, "queries": 4}
    )
    # Ties: equal distances rank by database index, so the result is deterministic.
    tied = ranked_relevance(np.zeros((1, 3)), ["a"], ["b", "a", "a"])
    np.testing.assert_array_equal(tied[0], [False, True, True])


def test_queries_without_relevant_models_are_not_scored() -> None:
    # A class of one (after excluding itself) cannot be retrieved: it is skipped, not zero.
    relevance = [RANKING, np.zeros(5, dtype=bool)]
    scores = score_rankings(relevance)
    assert scores["queries"] == 1
    assert scores["nn"] == 1.0


def test_pairwise_distances_match_numpy() -> None:
    rng = np.random.default_rng(0)
    a, b = rng.normal(size=(4, 7)), rng.normal(size=(5, 7))
    expected = np.linalg.norm(a[:, None, :] - b[None, :, :], axis=2)
    np.testing.assert_allclose(pairwise_distances(a, b), expected, atol=1e-12)
    assert np.all(np.diag(pairwise_distances(a, a)) >= 0)


def test_per_class_scores_name_each_kind_s_wrong_first_answers() -> None:
    # Five models on a line: screws at 0 and 1, a washer at 1.2, nuts at 5 and 9.
    positions = np.array([0.0, 1.0, 1.2, 5.0, 9.0])
    labels = ["screw", "screw", "washer", "nut", "nut"]
    distances = np.abs(positions[:, None] - positions[None, :])
    table = per_class_scores(distances, labels, labels, np.eye(5, dtype=bool))
    # The washer has no classmate: not scored. Screw at 1 finds the washer first (0.2).
    assert set(table) == {"screw", "nut"}
    assert table["screw"]["queries"] == 2
    assert table["screw"]["nn"] == pytest.approx(0.5)
    assert table["screw"]["map"] == pytest.approx((1.0 + 0.5) / 2)
    assert table["screw"]["mistakes"] == {"washer": 1}
    # The nut at 5 ranks the washer (3.8) and the screw at 1 (4, a tie broken by index)
    # before the nut at 9 (4); the nut at 9 finds the one at 5 first.
    assert table["nut"]["nn"] == pytest.approx(0.5)
    assert table["nut"]["map"] == pytest.approx((1 / 3 + 1.0) / 2)
    assert table["nut"]["mistakes"] == {"washer": 1}
