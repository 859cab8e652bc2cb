from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from typing import cast
from uuid import UUID

if TYPE_CHECKING:
  from ..models.where_used_entry import WhereUsedEntry





T = TypeVar("T", bound="WhereUsedResponse")



@_attrs_define
class WhereUsedResponse:
    """ 
        Attributes:
            assemblies (list[WhereUsedEntry]): Oldest assembly first.
            model_id (UUID):
     """

    assemblies: list[WhereUsedEntry]
    model_id: UUID
    additional_properties: dict[str, Any] = _attrs_field(init=False, factory=dict)





    def to_dict(self) -> dict[str, Any]:
        from ..models.where_used_entry import WhereUsedEntry # noqa: PLC0415
        assemblies = []
        for assemblies_item_data in self.assemblies:
            assemblies_item = assemblies_item_data.to_dict()
            assemblies.append(assemblies_item)



        model_id = str(self.model_id)


        field_dict: dict[str, Any] = {}
        field_dict.update(self.additional_properties)
        field_dict.update({
            "assemblies": assemblies,
            "model_id": model_id,
        })

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        from ..models.where_used_entry import WhereUsedEntry # noqa: PLC0415
        d = dict(src_dict)
        assemblies = []
        _assemblies = d.pop("assemblies")
        for assemblies_item_data in (_assemblies):
            assemblies_item = WhereUsedEntry.from_dict(assemblies_item_data)



            assemblies.append(assemblies_item)


        model_id = UUID(d.pop("model_id"))




        where_used_response = cls(
            assemblies=assemblies,
            model_id=model_id,
        )


        where_used_response.additional_properties = d
        return where_used_response

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
