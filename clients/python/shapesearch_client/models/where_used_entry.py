from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from typing import cast
from uuid import UUID

if TYPE_CHECKING:
  from ..models.model_summary import ModelSummary





T = TypeVar("T", bound="WhereUsedEntry")



@_attrs_define
class WhereUsedEntry:
    """ One assembly that uses a part (issue 76, ``app.api.routes.assemblies``).

        Attributes:
            assembly (ModelSummary):
            count (int): How many times it places the part (or its copies).
            parts (list[UUID]): The part models of that assembly that matched: the part itself, or parts the index finds to
                be copies of it (likeness `copy`, sizes within 3 %).
     """

    assembly: ModelSummary
    count: int
    parts: list[UUID]
    additional_properties: dict[str, Any] = _attrs_field(init=False, factory=dict)





    def to_dict(self) -> dict[str, Any]:
        from ..models.model_summary import ModelSummary # noqa: PLC0415
        assembly = self.assembly.to_dict()

        count = self.count

        parts = []
        for parts_item_data in self.parts:
            parts_item = str(parts_item_data)
            parts.append(parts_item)




        field_dict: dict[str, Any] = {}
        field_dict.update(self.additional_properties)
        field_dict.update({
            "assembly": assembly,
            "count": count,
            "parts": parts,
        })

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        from ..models.model_summary import ModelSummary # noqa: PLC0415
        d = dict(src_dict)
        assembly = ModelSummary.from_dict(d.pop("assembly"))




        count = d.pop("count")

        parts = []
        _parts = d.pop("parts")
        for parts_item_data in (_parts):
            parts_item = UUID(parts_item_data)



            parts.append(parts_item)


        where_used_entry = cls(
            assembly=assembly,
            count=count,
            parts=parts,
        )


        where_used_entry.additional_properties = d
        return where_used_entry

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
