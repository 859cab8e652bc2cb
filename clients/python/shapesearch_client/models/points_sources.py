from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from ..models.points_sources_model import PointsSourcesModel
from ..models.points_sources_other import PointsSourcesOther






T = TypeVar("T", bound="PointsSources")



@_attrs_define
class PointsSources:
    """ Each part's points: its stored sample (the description's points in its file's units),
    or, for a model described before samples were kept, its preview's 2000 points scaled
    back by the square root of its surface area (centred: the translation is then relative
    to its centre). Re-describe a model to get its sample.

        Attributes:
            model (PointsSourcesModel):
            other (PointsSourcesOther):
     """

    model: PointsSourcesModel
    other: PointsSourcesOther
    additional_properties: dict[str, Any] = _attrs_field(init=False, factory=dict)





    def to_dict(self) -> dict[str, Any]:
        model = self.model.value

        other = self.other.value


        field_dict: dict[str, Any] = {}
        field_dict.update(self.additional_properties)
        field_dict.update({
            "model": model,
            "other": other,
        })

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        d = dict(src_dict)
        model = PointsSourcesModel(d.pop("model"))




        other = PointsSourcesOther(d.pop("other"))




        points_sources = cls(
            model=model,
            other=other,
        )


        points_sources.additional_properties = d
        return points_sources

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
