from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from typing import cast
from uuid import UUID

if TYPE_CHECKING:
  from ..models.part_use import PartUse





T = TypeVar("T", bound="PartsResponse")



@_attrs_define
class PartsResponse:
    """ 
        Attributes:
            assembly_id (UUID):
            parts (list[PartUse]): The distinct parts, in the order the file first places them; empty for a model that was
                not uploaded as a split assembly.
     """

    assembly_id: UUID
    parts: list[PartUse]
    additional_properties: dict[str, Any] = _attrs_field(init=False, factory=dict)





    def to_dict(self) -> dict[str, Any]:
        from ..models.part_use import PartUse # noqa: PLC0415
        assembly_id = str(self.assembly_id)

        parts = []
        for parts_item_data in self.parts:
            parts_item = parts_item_data.to_dict()
            parts.append(parts_item)




        field_dict: dict[str, Any] = {}
        field_dict.update(self.additional_properties)
        field_dict.update({
            "assembly_id": assembly_id,
            "parts": parts,
        })

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        from ..models.part_use import PartUse # noqa: PLC0415
        d = dict(src_dict)
        assembly_id = UUID(d.pop("assembly_id"))




        parts = []
        _parts = d.pop("parts")
        for parts_item_data in (_parts):
            parts_item = PartUse.from_dict(parts_item_data)



            parts.append(parts_item)


        parts_response = cls(
            assembly_id=assembly_id,
            parts=parts,
        )


        parts_response.additional_properties = d
        return parts_response

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
