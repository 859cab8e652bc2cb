"""The calibrated score (core.rank.score_calibration): the share of different-kind pairs of the
tuning sources scoring lower, shipped for the default descriptor layout."""

from __future__ import annotations

import numpy as np
import pytest
from fastapi.testclient import TestClient

from app.api.main import create_app
from app.ingest.describing import descriptor_version
from core.rank.score_calibration import (
    LIKENESS,
    ScoreCalibration,
    calibration_for,
    in_words,
    layout_of,
)
from core.settings import EngineSettings
from tests.conftest import PARTS, fake_describe, make_settings, upload, wait_for_status


def test_it_is_the_empirical_share_below_and_never_decreases() -> None:
    scores = np.random.default_rng(0).beta(8, 1, size=5000)
    calibration = ScoreCalibration(np.quantile(scores, np.linspace(0, 1, 1001)))
    for probe in (0.5, 0.8, 0.9, 0.97):
        assert calibration(probe) == pytest.approx(np.mean(scores < probe), abs=2e-3)
    mapped = [calibration(s) for s in np.linspace(0, 1, 201)]
    assert np.all(np.diff(mapped) >= 0) and mapped[0] == 0.0 and mapped[-1] == 1.0


def test_the_default_descriptor_is_calibrated_whatever_its_library_digest() -> None:
    # Fails when the default descriptor changes without
    # `python -m research.artefacts.score_calibration --write`.
    version = descriptor_version(EngineSettings())
    calibration = calibration_for(version)
    assert calibration is not None
    assert calibration_for(layout_of(version) + ";0123456789") is calibration
    # Different kinds reach 0.95 often on the raw scale; the calibrated one says how often.
    assert 0.5 < calibration(0.95) < 0.99 and calibration(0.999) > 0.99


def test_another_layout_has_no_calibration() -> None:
    assert calibration_for("fake-1") is None


@pytest.mark.slow
def test_results_of_the_default_layout_carry_it(database_url: str) -> None:
    default = descriptor_version(EngineSettings())

    def describe_as_default(content: bytes, filename: str) -> dict[str, object]:
        return {**fake_describe(content, filename), "descriptor_version": default}

    app = create_app(make_settings(database_url), embedded_worker=True,
                     job_handler=describe_as_default)
    with TestClient(app) as client:
        ids = [upload(client, PARTS / name).json()["id"]
               for name in ("20mm-xyz-cube.stl", "round.stl", "cylinder.stl")]
        for model_id in ids:
            wait_for_status(client, model_id)
        results = client.get(f"/v1/models/{ids[0]}/similar").json()["results"]
    calibration = calibration_for(default)
    assert calibration is not None and len(results) == 2
    for result in results:
        assert result["calibrated_score"] == pytest.approx(calibration(result["score"]))
        assert result["likeness"] == in_words(result["calibrated_score"])


def test_a_calibrated_score_reads_in_words() -> None:
    assert [words for _, words in LIKENESS] == ["copy", "same kind", "different kind"]
    assert in_words(0.999) == in_words(0.995) == "copy"
    assert in_words(0.99) == in_words(0.95) == "same kind"
    assert in_words(0.9) == in_words(0.0) == "different kind"
    # On the default layout's raw scale: copies score about 0.985 and up, same-kind pairs
    # about 0.96 and up (README, "What a score means").
    calibration = calibration_for(descriptor_version(EngineSettings()))
    assert calibration is not None
    assert in_words(calibration(0.99)) == "copy"
    assert in_words(calibration(0.97)) == "same kind"
    assert in_words(calibration(0.93)) == "different kind"
