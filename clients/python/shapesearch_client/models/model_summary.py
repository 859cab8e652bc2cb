from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from typing import cast
from uuid import UUID

if TYPE_CHECKING:
  from ..models.model_summary_metadata import ModelSummaryMetadata
  from ..models.size import Size





T = TypeVar("T", bound="ModelSummary")



@_attrs_define
class ModelSummary:
    """ 
        Attributes:
            external_id (None | str):
            id (UUID):
            metadata (ModelSummaryMetadata):
            name (None | str):
            size (None | Size):
     """

    external_id: None | str
    id: UUID
    metadata: ModelSummaryMetadata
    name: None | str
    size: None | Size
    additional_properties: dict[str, Any] = _attrs_field(init=False, factory=dict)





    def to_dict(self) -> dict[str, Any]:
        from ..models.model_summary_metadata import ModelSummaryMetadata # noqa: PLC0415
        from ..models.size import Size # noqa: PLC0415
        external_id: None | str
        external_id = self.external_id

        id = str(self.id)

        metadata = self.metadata.to_dict()

        name: None | str
        name = self.name

        size: dict[str, Any] | None
        if isinstance(self.size, Size):
            size = self.size.to_dict()
        else:
            size = self.size


        field_dict: dict[str, Any] = {}
        field_dict.update(self.additional_properties)
        field_dict.update({
            "external_id": external_id,
            "id": id,
            "metadata": metadata,
            "name": name,
            "size": size,
        })

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        from ..models.model_summary_metadata import ModelSummaryMetadata # noqa: PLC0415
        from ..models.size import Size # noqa: PLC0415
        d = dict(src_dict)
        def _parse_external_id(data: object) -> None | str:
            if data is None:
                return data
            return cast(None | str, data)

        external_id = _parse_external_id(d.pop("external_id"))


        id = UUID(d.pop("id"))




        metadata = ModelSummaryMetadata.from_dict(d.pop("metadata"))




        def _parse_name(data: object) -> None | str:
            if data is None:
                return data
            return cast(None | str, data)

        name = _parse_name(d.pop("name"))


        def _parse_size(data: object) -> None | Size:
            if data is None:
                return data
            try:
                if not isinstance(data, dict):
                    raise TypeError()
                size_type_0 = Size.from_dict(data)



                return size_type_0
            except (TypeError, ValueError, AttributeError, KeyError):
                pass
            return cast(None | Size, data)

        size = _parse_size(d.pop("size"))


        model_summary = cls(
            external_id=external_id,
            id=id,
            metadata=metadata,
            name=name,
            size=size,
        )


        model_summary.additional_properties = d
        return model_summary

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
