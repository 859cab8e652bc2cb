"""Builders of the data ``core/data`` ships, beside each other.

- ``score_calibration``: ``score-calibration.json``, the different-kind score quantiles per
  descriptor layout (``core.rank.score_calibration``);
- ``vocabulary``: ``hks-sv64.npz`` and ``hks64.npz``, the local words of the two descriptor
  families (``core.local_features.Vocabulary``).

Each is a slow step (describing the tuning sources) and a deterministic final step, which
``tests/evaluation/test_artefacts.py`` checks against the shipped files.
"""
