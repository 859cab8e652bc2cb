from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from ..models.compare_response_units_type_0 import CompareResponseUnitsType0
from ..types import UNSET, Unset
from typing import cast

if TYPE_CHECKING:
  from ..models.alignment_record import AlignmentRecord
  from ..models.compare_points import ComparePoints
  from ..models.deviation_figures import DeviationFigures
  from ..models.extents import Extents
  from ..models.model_summary import ModelSummary
  from ..models.points_sources import PointsSources





T = TypeVar("T", bound="CompareResponse")



@_attrs_define
class CompareResponse:
    """ ``other`` placed on ``model``, and how far apart they are, in ``model``'s units.

        Attributes:
            alignment (AlignmentRecord): A rigid placement (with a uniform scale) of one point set on another: a point ``p``
                of the placed part lands at ``scale * rotation @ p + translation``.
            extents (Extents):
            model (ModelSummary):
            model_to_other (DeviationFigures): How far one part's points lie from the other part's surface (its sample
                points, each
                taken as the small disc of surface it stands for), in the reference's units.
            other (ModelSummary):
            other_to_model (DeviationFigures): How far one part's points lie from the other part's surface (its sample
                points, each
                taken as the small disc of surface it stands for), in the reference's units.
            points_source (PointsSources): Each part's points: its stored sample (the description's points in its file's
                units),
                or, for a model described before samples were kept, its preview's 2000 points scaled
                back by the square root of its surface area (centred: the translation is then relative
                to its centre). Re-describe a model to get its sample.
            size_ratios (list[float]): The other part's extents over the model's, along the model's principal axes (largest
                spread first): 1.1 = 10 % longer.
            tolerance (float):
            units (CompareResponseUnitsType0 | None): The units of every length here: the model's (null: not declared; the
                other's points are converted when both declare theirs, else compared as given).
            points (ComparePoints | None | Unset): With `points=N`: up to N points of each part (a part has at most 3000),
                aligned, with their deviations.
     """

    alignment: AlignmentRecord
    extents: Extents
    model: ModelSummary
    model_to_other: DeviationFigures
    other: ModelSummary
    other_to_model: DeviationFigures
    points_source: PointsSources
    size_ratios: list[float]
    tolerance: float
    units: CompareResponseUnitsType0 | None
    points: ComparePoints | None | Unset = UNSET
    additional_properties: dict[str, Any] = _attrs_field(init=False, factory=dict)





    def to_dict(self) -> dict[str, Any]:
        from ..models.alignment_record import AlignmentRecord # noqa: PLC0415
        from ..models.compare_points import ComparePoints # noqa: PLC0415
        from ..models.deviation_figures import DeviationFigures # noqa: PLC0415
        from ..models.extents import Extents # noqa: PLC0415
        from ..models.model_summary import ModelSummary # noqa: PLC0415
        from ..models.points_sources import PointsSources # noqa: PLC0415
        alignment = self.alignment.to_dict()

        extents = self.extents.to_dict()

        model = self.model.to_dict()

        model_to_other = self.model_to_other.to_dict()

        other = self.other.to_dict()

        other_to_model = self.other_to_model.to_dict()

        points_source = self.points_source.to_dict()

        size_ratios = self.size_ratios



        tolerance = self.tolerance

        units: None | str
        if isinstance(self.units, CompareResponseUnitsType0):
            units = self.units.value
        else:
            units = self.units

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
            "extents": extents,
            "model": model,
            "model_to_other": model_to_other,
            "other": other,
            "other_to_model": other_to_model,
            "points_source": points_source,
            "size_ratios": size_ratios,
            "tolerance": tolerance,
            "units": units,
        })
        if points is not UNSET:
            field_dict["points"] = points

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        from ..models.alignment_record import AlignmentRecord # noqa: PLC0415
        from ..models.compare_points import ComparePoints # noqa: PLC0415
        from ..models.deviation_figures import DeviationFigures # noqa: PLC0415
        from ..models.extents import Extents # noqa: PLC0415
        from ..models.model_summary import ModelSummary # noqa: PLC0415
        from ..models.points_sources import PointsSources # noqa: PLC0415
        d = dict(src_dict)
        alignment = AlignmentRecord.from_dict(d.pop("alignment"))




        extents = Extents.from_dict(d.pop("extents"))




        model = ModelSummary.from_dict(d.pop("model"))




        model_to_other = DeviationFigures.from_dict(d.pop("model_to_other"))




        other = ModelSummary.from_dict(d.pop("other"))




        other_to_model = DeviationFigures.from_dict(d.pop("other_to_model"))




        points_source = PointsSources.from_dict(d.pop("points_source"))




        size_ratios = cast(list[float], d.pop("size_ratios"))


        tolerance = d.pop("tolerance")

        def _parse_units(data: object) -> CompareResponseUnitsType0 | None:
            if data is None:
                return data
            try:
                if not isinstance(data, str):
                    raise TypeError()
                units_type_0 = CompareResponseUnitsType0(data)



                return units_type_0
            except (TypeError, ValueError, AttributeError, KeyError):
                pass
            return cast(CompareResponseUnitsType0 | None, data)

        units = _parse_units(d.pop("units"))


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


        compare_response = cls(
            alignment=alignment,
            extents=extents,
            model=model,
            model_to_other=model_to_other,
            other=other,
            other_to_model=other_to_model,
            points_source=points_source,
            size_ratios=size_ratios,
            tolerance=tolerance,
            units=units,
            points=points,
        )


        compare_response.additional_properties = d
        return compare_response

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
