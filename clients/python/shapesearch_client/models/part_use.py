from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from typing import cast

if TYPE_CHECKING:
  from ..models.model_summary import ModelSummary





T = TypeVar("T", bound="PartUse")



@_attrs_define
class PartUse:
    """ 
        Attributes:
            count (int): How many times the assembly places it.
            model (ModelSummary):
            placements (list[list[float]]): Each instance's 4x4 transform from the part's frame to the assembly's, 16
                numbers row-major (translation in the 4th, 8th and 12th).
     """

    count: int
    model: ModelSummary
    placements: list[list[float]]
    additional_properties: dict[str, Any] = _attrs_field(init=False, factory=dict)





    def to_dict(self) -> dict[str, Any]:
        from ..models.model_summary import ModelSummary # noqa: PLC0415
        count = self.count

        model = self.model.to_dict()

        placements = []
        for placements_item_data in self.placements:
            placements_item = placements_item_data


            placements.append(placements_item)




        field_dict: dict[str, Any] = {}
        field_dict.update(self.additional_properties)
        field_dict.update({
            "count": count,
            "model": model,
            "placements": placements,
        })

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        from ..models.model_summary import ModelSummary # noqa: PLC0415
        d = dict(src_dict)
        count = d.pop("count")

        model = ModelSummary.from_dict(d.pop("model"))




        placements = []
        _placements = d.pop("placements")
        for placements_item_data in (_placements):
            placements_item = cast(list[float], placements_item_data)

            placements.append(placements_item)


        part_use = cls(
            count=count,
            model=model,
            placements=placements,
        )


        part_use.additional_properties = d
        return part_use

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
