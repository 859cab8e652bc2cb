from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from ..models.revision_resource_status import RevisionResourceStatus
from typing import cast
from uuid import UUID
import datetime

if TYPE_CHECKING:
  from ..models.file_info import FileInfo





T = TypeVar("T", bound="RevisionResource")



@_attrs_define
class RevisionResource:
    """ 
        Attributes:
            created_at (datetime.datetime):
            file (FileInfo):
            id (UUID):
            number (int): 1 for the first file, then 2, 3, ...
            status (RevisionResourceStatus): current: the file the descriptor comes from; pending: being described.
     """

    created_at: datetime.datetime
    file: FileInfo
    id: UUID
    number: int
    status: RevisionResourceStatus
    additional_properties: dict[str, Any] = _attrs_field(init=False, factory=dict)





    def to_dict(self) -> dict[str, Any]:
        from ..models.file_info import FileInfo # noqa: PLC0415
        created_at = self.created_at.isoformat()

        file = self.file.to_dict()

        id = str(self.id)

        number = self.number

        status = self.status.value


        field_dict: dict[str, Any] = {}
        field_dict.update(self.additional_properties)
        field_dict.update({
            "created_at": created_at,
            "file": file,
            "id": id,
            "number": number,
            "status": status,
        })

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        from ..models.file_info import FileInfo # noqa: PLC0415
        d = dict(src_dict)
        created_at = datetime.datetime.fromisoformat(d.pop("created_at"))




        file = FileInfo.from_dict(d.pop("file"))




        id = UUID(d.pop("id"))




        number = d.pop("number")

        status = RevisionResourceStatus(d.pop("status"))




        revision_resource = cls(
            created_at=created_at,
            file=file,
            id=id,
            number=number,
            status=status,
        )


        revision_resource.additional_properties = d
        return revision_resource

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
