from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from typing import cast






T = TypeVar("T", bound="PointSet")



@_attrs_define
class PointSet:
    """ 
        Attributes:
            deviations (list[float]): Each point's distance from the other part, in the reference's units.
            positions (list[list[float]]): Points [x, y, z] in the reference's frame and units.
     """

    deviations: list[float]
    positions: list[list[float]]
    additional_properties: dict[str, Any] = _attrs_field(init=False, factory=dict)





    def to_dict(self) -> dict[str, Any]:
        deviations = self.deviations



        positions = []
        for positions_item_data in self.positions:
            positions_item = positions_item_data


            positions.append(positions_item)




        field_dict: dict[str, Any] = {}
        field_dict.update(self.additional_properties)
        field_dict.update({
            "deviations": deviations,
            "positions": positions,
        })

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        d = dict(src_dict)
        deviations = cast(list[float], d.pop("deviations"))


        positions = []
        _positions = d.pop("positions")
        for positions_item_data in (_positions):
            positions_item = cast(list[float], positions_item_data)

            positions.append(positions_item)


        point_set = cls(
            deviations=deviations,
            positions=positions,
        )


        point_set.additional_properties = d
        return point_set

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
