"""Size in search: range filters, a tolerance around the query's size, and a size term in
the ranking.

Sizes are stored in each file's own units (``Model.units``: mm, cm, m, in, or NULL) and
compared in millimetres; a model without units is compared as given (its numbers taken as
millimetres), so a catalogue that never declares units behaves consistently.

* ``ranges``: ``size.length.gte=20`` and the like keep models whose extent (or area, volume)
  lies in the range, in millimetres (area mm^2, volume mm^3).
* ``tolerance`` t: keep models whose three extents are each within a factor ``1 +- t`` of
  the query's: ``|e_model / e_query - 1| <= t`` for length, width and height.
* ``weight`` w (default 0: descriptor distance only): the distance becomes
  ``D = sqrt(d^2 + w * sum_i ln(e_model,i / e_query,i)^2)`` over the three extents, and
  ``score = 1 - D^2 / 4`` as before, so a part at twice the size in every direction with
  an identical descriptor scores ``1 - 3 w ln(2)^2 / 4`` (0.64 at w = 1).

A model without a size (described before sizes were stored) passes no range and no
tolerance, and gets no size term.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from sqlalchemy import ColumnElement, select, true, union_all

from app.db.models import Model
from core.size import SIZE_FIELDS, UNIT_MILLIMETRES

__all__ = ["SIZE_FILTER_FIELDS", "SizeQuery", "extents_mm", "millimetres"]

#: The measurements a range filter may name (``size.<field>.gte`` / ``.lte``).
SIZE_FILTER_FIELDS = SIZE_FIELDS
_POWER = {"length": 1, "width": 1, "height": 1, "area": 2, "volume": 3}


def millimetres(units: str | None) -> float:
    """Millimetres per unit of ``units`` (1 when unknown: compared as given)."""
    return UNIT_MILLIMETRES.get(units or "", 1.0)


def extents_mm(
    length: float | None, width: float | None, height: float | None, units: str | None
) -> tuple[float, float, float] | None:
    """Stored extents in millimetres (as given without units); None without a size."""
    if length is None or width is None or height is None:
        return None
    scale = millimetres(units)
    return length * scale, width * scale, height * scale


@dataclass(frozen=True)
class SizeQuery:
    """What a query asks of sizes; all empty: nothing (today's ranking)."""

    extents: tuple[float, float, float] | None = None  # the query's, in millimetres
    tolerance: float | None = None
    weight: float = 0.0
    ranges: dict[str, tuple[float | None, float | None]] = field(default_factory=dict)

    @property
    def filters(self) -> bool:
        return bool(self.ranges) or self.tolerance is not None

    @property
    def active(self) -> bool:
        return self.filters or self.weight > 0

    def admits(self, row: Any) -> bool:
        """Whether a candidate row (with the size columns and ``units``) passes."""
        if not self.filters:
            return True
        if row.size_length is None:
            return False
        scale = millimetres(row.units)
        for name, (low, high) in self.ranges.items():
            value = getattr(row, f"size_{name}")
            if value is None:
                return False
            value *= scale ** _POWER[name]
            if (low is not None and value < low) or (high is not None and value > high):
                return False
        if self.tolerance is not None and self.extents is not None:
            ratios = self._ratios(row, scale)
            if np.any(np.abs(ratios - 1.0) > self.tolerance + 1e-12):
                return False
        return True

    def distance(self, descriptor_distance: float, row: Any) -> float:
        """The ranking distance of a candidate whose descriptor lies ``descriptor_distance``
        from the query's."""
        if self.weight <= 0 or self.extents is None or row.size_length is None:
            return descriptor_distance
        logs = np.log(self._ratios(row, millimetres(row.units)))
        return math.sqrt(descriptor_distance**2 + self.weight * float(np.sum(logs**2)))

    def _ratios(self, row: Any, scale: float) -> np.ndarray:
        assert self.extents is not None
        mine = np.array([row.size_length, row.size_width, row.size_height]) * scale
        return np.maximum(mine, 1e-12) / np.maximum(np.array(self.extents), 1e-12)

    def sql(self) -> ColumnElement[bool]:
        """A SQL condition true for every model that ``admits``: ``index_id`` among the
        union, over the units, of ``units = 'cm' AND size_length >= 2.0 AND ...`` (20 mm
        written in centimetres, and so on). Each branch is a range seek on the index of
        migration 0009 (units, sizes, ...), which also holds every column the bounds read:
        a 1%-selective range reads 1% of that index and never a row's descriptor. (A product
        ``size_length * scale(units)`` can use no index: it read every row.)"""
        bounds: list[tuple[str, float | None, float | None]] = [
            (name, low, high) for name, (low, high) in self.ranges.items()
        ]
        if self.tolerance is not None and self.extents is not None:
            margin = self.tolerance + 1e-9
            bounds += [
                (name, wanted * (1 - margin), wanted * (1 + margin))
                for name, wanted in zip(("length", "width", "height"), self.extents, strict=True)
            ]
        if not bounds:
            return true()
        branches = []
        for units, factor in [*UNIT_MILLIMETRES.items(), (None, 1.0)]:
            conditions: list[ColumnElement[bool]] = [
                Model.units.is_(None) if units is None else Model.units == units
            ]
            for name, low, high in bounds:
                column = getattr(Model, f"size_{name}")
                scale = factor ** _POWER[name]
                if low is not None:
                    conditions.append(column >= low / scale)
                if high is not None:
                    conditions.append(column <= high / scale)
            branches.append(select(Model.index_id).where(*conditions))
        return Model.index_id.in_(union_all(*branches))
