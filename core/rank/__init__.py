"""Ranking: what happens to a descriptor's nearest neighbours before they are answered.

- ``hubness``: the hub discount (a neighbour near everything counts for less);
- ``reciprocal``: k-reciprocal re-ranking of the first answers;
- ``scan_order``: how a scan's answers are ordered over a model's virtual views;
- ``score_calibration``: a distance turned into a score a person can read.
"""
