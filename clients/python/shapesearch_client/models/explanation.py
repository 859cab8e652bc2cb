from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from ..models.explanation_points_source import ExplanationPointsSource
from ..types import UNSET, Unset
from typing import cast

if TYPE_CHECKING:
  from ..models.alignment_record import AlignmentRecord
  from ..models.compare_points import ComparePoints





T = TypeVar("T", bound="Explanation")



@_attrs_define
class Explanation:
    """ The scan placed on this result: its alignment at the part's scale, how close it lies
    and how much of the part it covers.

        Attributes:
            alignment (AlignmentRecord): A rigid placement (with a uniform scale) of one point set on another: a point ``p``
                of the placed part lands at ``scale * rotation @ p + translation``.
            coverage (float): Share of the part's sample points within `tolerance` of the aligned scan: about half for one
                view of a closed part, near 1 for a full scan.
            points_source (ExplanationPointsSource): The part's points: its stored sample, or (described before samples were
                kept) its preview scaled back to its units.
            rms (float): RMS distance of the scan's points from the part's surface, in the part's units.
            tolerance (float): 1 % of the larger bounding-box diagonal, in the part's units.
            view (int | None): In scan mode, the part's virtual view whose descriptor matched (0-based); null: its whole
                descriptor (and always in shape mode).
            points (ComparePoints | None | Unset): With `points=N`: up to N points of the part (model) and of the aligned
                scan (other) with their deviations.
     """

    alignment: AlignmentRecord
    coverage: float
    points_source: ExplanationPointsSource
    rms: float
    tolerance: float
    view: int | None
    points: ComparePoints | None | Unset = UNSET
    additional_properties: dict[str, Any] = _attrs_field(init=False, factory=dict)





    def to_dict(self) -> dict[str, Any]:
        from ..models.alignment_record import AlignmentRecord # noqa: PLC0415
        from ..models.compare_points import ComparePoints # noqa: PLC0415
        alignment = self.alignment.to_dict()

        coverage = self.coverage

        points_source = self.points_source.value

        rms = self.rms

        tolerance = self.tolerance

        view: int | None
        view = self.view

        points: dict[str, Any] | None | Unset
        if isinstance(self.points, Unset):
            points = UNSET
        elif isinstance(self.points, ComparePoints):
            points = self.points.to_dict()
        else:
            points = self.points


        field_dict: dict[str, Any] = {}
        field_dict.update(self.additional_properties)
        field_dict.update({
            "alignment": alignment,
            "coverage": coverage,
            "points_source": points_source,
            "rms": rms,
            "tolerance": tolerance,
            "view": view,
        })
        if points is not UNSET:
            field_dict["points"] = points

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        from ..models.alignment_record import AlignmentRecord # noqa: PLC0415
        from ..models.compare_points import ComparePoints # noqa: PLC0415
        d = dict(src_dict)
        alignment = AlignmentRecord.from_dict(d.pop("alignment"))




        coverage = d.pop("coverage")

        points_source = ExplanationPointsSource(d.pop("points_source"))




        rms = d.pop("rms")

        tolerance = d.pop("tolerance")

        def _parse_view(data: object) -> int | None:
            if data is None:
                return data
            return cast(int | None, data)

        view = _parse_view(d.pop("view"))


        def _parse_points(data: object) -> ComparePoints | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            try:
                if not isinstance(data, dict):
                    raise TypeError()
                points_type_0 = ComparePoints.from_dict(data)



                return points_type_0
            except (TypeError, ValueError, AttributeError, KeyError):
                pass
            return cast(ComparePoints | None | Unset, data)

        points = _parse_points(d.pop("points", UNSET))


        explanation = cls(
            alignment=alignment,
            coverage=coverage,
            points_source=points_source,
            rms=rms,
            tolerance=tolerance,
            view=view,
            points=points,
        )


        explanation.additional_properties = d
        return explanation

    @property
    def additional_keys(self) -> list[str]:
        return list(self.additional_properties.keys())

    def __getitem__(self, key: str) -> Any:
        return self.additional_properties[key]

    def __setitem__(self, key: str, value: Any) -> None:
        self.additional_properties[key] = value

    def __delitem__(self, key: str) -> None:
        del self.additional_properties[key]

    def __contains__(self, key: str) -> bool:
        return key in self.additional_properties
