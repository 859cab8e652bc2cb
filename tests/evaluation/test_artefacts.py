"""The builders of the shipped data (``research/artefacts``) and the files they wrote.

What these tests prove, and what they do not. No slow step runs here: the score calibration
describes 468 models of five tuning sources (minutes, and two of the sources need build123d
in a venv of its own), the vocabularies need stage 1 of a study (hours of extraction). Each
builder is a slow step and a deterministic final step, and the final step is what is tested:

- score calibration: its intermediate is committed (``research/artefacts/
  score-calibration-pairs.npz``, every pair's score, written by the slow step on 2026-12-07
  from the sources rebuilt that day with the default ``ss12``), and the final step writes the
  shipped file from it byte for byte. So the shipped quantiles are those pairs', the file's
  newest entry is the current default's layout, the earlier layouts are kept as they are,
  and rounding, order and format are the builder's. It does not re-describe the sources:
  that the intermediate is still what today's descriptor gives is checked by re-running the
  slow step (the command in the builder's docstring), not here.
- vocabularies: each shipped file is what the builder's writer writes for its words, byte for
  byte, its digest is the one its family's ``descriptor_version`` names, and the fit is
  deterministic with the shipped shape (64 words of 18 or 16 columns). It does not prove the
  shipped words refit from today's sources: they do not (the sources and the extraction have
  moved since they were fitted; research/artefacts/vocabulary.py gives the figures).
"""

from __future__ import annotations

import io
import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from core.descriptor import DescriptorSpec
from core.local_features import Vocabulary
from core.rank.score_calibration import CALIBRATION_FILE
from core.settings import EngineSettings
from research.artefacts.score_calibration import (
    GROUPS,
    PAIRS,
    calibration_text,
    default_layout,
    load_scores,
    save_scores,
)
from research.artefacts.vocabulary import DATA, VOCABULARIES
from research.study import WORDS, fit_words


def test_the_final_step_writes_the_shipped_calibration_from_its_intermediate() -> None:
    shipped = CALIBRATION_FILE.read_text()
    table = json.loads(shipped)
    layouts = table["different_kind_quantiles"]
    layout = default_layout()
    assert list(layouts)[-1] == layout  # the newest entry is the default's
    scores = load_scores(PAIRS)
    groups = {g: np.concatenate([s[g] for s in scores.values()]) for g in GROUPS}
    assert {g: v.size for g, v in groups.items()} == table["pairs"]
    earlier = {name: q for name, q in layouts.items() if name != layout}
    pairs = {g: int(v.size) for g, v in groups.items()}
    assert calibration_text(groups["different"], pairs, layout, earlier) == shipped


def test_the_final_step_keeps_earlier_layouts_and_adds_a_new_one_last() -> None:
    scores = np.random.default_rng(0).beta(8, 1, size=2000)
    earlier = {"older": [0.0, 1.0]}
    table = json.loads(calibration_text(scores, {"different": 2000}, "new", earlier))
    quantiles = table["different_kind_quantiles"]
    assert list(quantiles) == ["older", "new"] and quantiles["older"] == [0.0, 1.0]
    assert len(quantiles["new"]) == 1001 and quantiles["new"][0] == round(scores.min(), 6)
    assert quantiles["new"][500] == round(float(np.median(scores)), 6)


def test_the_intermediate_keeps_every_score_sorted(tmp_path: Path) -> None:
    scores = {"parts": {"copy": np.array([0.99, 0.98]), "different": np.array([0.8])},
              "madcad": {"same kind": np.array([0.95]), "different": np.array([])}}
    save_scores(tmp_path / "pairs.npz", scores)
    loaded = load_scores(tmp_path / "pairs.npz")
    assert loaded.keys() == scores.keys()
    for source, groups in scores.items():
        for group, values in groups.items():
            np.testing.assert_array_equal(loaded[source][group], np.sort(values))


@pytest.mark.parametrize("name", sorted(VOCABULARIES))
def test_each_shipped_vocabulary_is_the_builders_file_and_its_familys(name: str) -> None:
    path = DATA / f"{name}.npz"
    vocabulary = Vocabulary.load(path)
    written = io.BytesIO()
    vocabulary.save(written)
    assert written.getvalue() == path.read_bytes()
    family = VOCABULARIES[name]
    settings = replace(EngineSettings(), descriptor=family)
    version = DescriptorSpec.from_settings(family).version(settings)
    assert f"@{vocabulary.digest()[:6]}" in version
    width = len(family.hks_times) + len(family.local_neighbours)
    assert (vocabulary.size, vocabulary.width) == (WORDS, width)


def test_the_fit_is_deterministic_and_has_the_shipped_shape() -> None:
    rng = np.random.default_rng(1)
    features = [rng.normal(size=(300, 18)) + rng.normal(size=18) for _ in range(40)]
    first, second = fit_words(features), fit_words(features)
    assert first.digest() == second.digest()
    assert (first.size, first.width) == (64, 18)
