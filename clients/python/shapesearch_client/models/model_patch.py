from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from ..types import UNSET, Unset
from typing import cast

if TYPE_CHECKING:
  from ..models.model_patch_metadata import ModelPatchMetadata





T = TypeVar("T", bound="ModelPatch")



@_attrs_define
class ModelPatch:
    """ Fields to change; absent fields stay as they are.

        Attributes:
            metadata (ModelPatchMetadata | Unset): Replaces the metadata; {} clears it. A JSON object, nested at most
                SHAPESEARCH_MAX_METADATA_DEPTH levels (default 8), at most SHAPESEARCH_MAX_METADATA_BYTES (default 16384) as
                compact JSON, its keys and strings without NUL at every level (else 422 validation-error pointing into it).
            name (None | str | Unset): null clears the name.
     """

    metadata: ModelPatchMetadata | Unset = UNSET
    name: None | str | Unset = UNSET





    def to_dict(self) -> dict[str, Any]:
        from ..models.model_patch_metadata import ModelPatchMetadata # noqa: PLC0415
        metadata: dict[str, Any] | Unset = UNSET
        if not isinstance(self.metadata, Unset):
            metadata = self.metadata.to_dict()

        name: None | str | Unset
        if isinstance(self.name, Unset):
            name = UNSET
        else:
            name = self.name


        field_dict: dict[str, Any] = {}

        field_dict.update({
        })
        if metadata is not UNSET:
            field_dict["metadata"] = metadata
        if name is not UNSET:
            field_dict["name"] = name

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        from ..models.model_patch_metadata import ModelPatchMetadata # noqa: PLC0415
        d = dict(src_dict)
        _metadata = d.pop("metadata", UNSET)
        metadata: ModelPatchMetadata | Unset
        if isinstance(_metadata,  Unset):
            metadata = UNSET
        else:
            metadata = ModelPatchMetadata.from_dict(_metadata)




        def _parse_name(data: object) -> None | str | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(None | str | Unset, data)

        name = _parse_name(d.pop("name", UNSET))


        model_patch = cls(
            metadata=metadata,
            name=name,
        )

        return model_patch

