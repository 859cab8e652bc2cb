from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from typing import cast

if TYPE_CHECKING:
  from ..models.point_set import PointSet





T = TypeVar("T", bound="ComparePoints")



@_attrs_define
class ComparePoints:
    """ Sample points of both parts, aligned, each with its deviation (for colouring).

        Attributes:
            model (PointSet):
            other (PointSet):
     """

    model: PointSet
    other: PointSet
    additional_properties: dict[str, Any] = _attrs_field(init=False, factory=dict)





    def to_dict(self) -> dict[str, Any]:
        from ..models.point_set import PointSet # noqa: PLC0415
        model = self.model.to_dict()

        other = self.other.to_dict()


        field_dict: dict[str, Any] = {}
        field_dict.update(self.additional_properties)
        field_dict.update({
            "model": model,
            "other": other,
        })

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        from ..models.point_set import PointSet # noqa: PLC0415
        d = dict(src_dict)
        model = PointSet.from_dict(d.pop("model"))




        other = PointSet.from_dict(d.pop("other"))




        compare_points = cls(
            model=model,
            other=other,
        )


        compare_points.additional_properties = d
        return compare_points

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
