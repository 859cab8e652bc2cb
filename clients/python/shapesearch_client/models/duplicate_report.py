from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from typing import cast

if TYPE_CHECKING:
  from ..models.duplicate_group_resource import DuplicateGroupResource





T = TypeVar("T", bound="DuplicateReport")



@_attrs_define
class DuplicateReport:
    """ 
        Attributes:
            descriptor_version (str):
            groups (list[DuplicateGroupResource]): Largest groups first.
            min_score (float):
            next_cursor (None | str): Pass as `cursor` for the next page; null: last.
            size_tolerance (float | None): As asked: null groups parts of any size (families), a number parts of the same
                size.
     """

    descriptor_version: str
    groups: list[DuplicateGroupResource]
    min_score: float
    next_cursor: None | str
    size_tolerance: float | None
    additional_properties: dict[str, Any] = _attrs_field(init=False, factory=dict)





    def to_dict(self) -> dict[str, Any]:
        from ..models.duplicate_group_resource import DuplicateGroupResource # noqa: PLC0415
        descriptor_version = self.descriptor_version

        groups = []
        for groups_item_data in self.groups:
            groups_item = groups_item_data.to_dict()
            groups.append(groups_item)



        min_score = self.min_score

        next_cursor: None | str
        next_cursor = self.next_cursor

        size_tolerance: float | None
        size_tolerance = self.size_tolerance


        field_dict: dict[str, Any] = {}
        field_dict.update(self.additional_properties)
        field_dict.update({
            "descriptor_version": descriptor_version,
            "groups": groups,
            "min_score": min_score,
            "next_cursor": next_cursor,
            "size_tolerance": size_tolerance,
        })

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        from ..models.duplicate_group_resource import DuplicateGroupResource # noqa: PLC0415
        d = dict(src_dict)
        descriptor_version = d.pop("descriptor_version")

        groups = []
        _groups = d.pop("groups")
        for groups_item_data in (_groups):
            groups_item = DuplicateGroupResource.from_dict(groups_item_data)



            groups.append(groups_item)


        min_score = d.pop("min_score")

        def _parse_next_cursor(data: object) -> None | str:
            if data is None:
                return data
            return cast(None | str, data)

        next_cursor = _parse_next_cursor(d.pop("next_cursor"))


        def _parse_size_tolerance(data: object) -> float | None:
            if data is None:
                return data
            return cast(float | None, data)

        size_tolerance = _parse_size_tolerance(d.pop("size_tolerance"))


        duplicate_report = cls(
            descriptor_version=descriptor_version,
            groups=groups,
            min_score=min_score,
            next_cursor=next_cursor,
            size_tolerance=size_tolerance,
        )


        duplicate_report.additional_properties = d
        return duplicate_report

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
