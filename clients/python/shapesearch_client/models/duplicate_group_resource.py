from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from typing import cast

if TYPE_CHECKING:
  from ..models.duplicate_member import DuplicateMember
  from ..models.duplicate_pair import DuplicatePair





T = TypeVar("T", bound="DuplicateGroupResource")



@_attrs_define
class DuplicateGroupResource:
    """ 
        Attributes:
            members (list[DuplicateMember]): Oldest model first.
            number (int): The group's place in the report, 1 = largest.
            pairs (list[DuplicatePair]): The edges that joined the group, best first: pairs at least min_score alike of
                which one is among the other's 16 most alike parts (at least size - 1 of them; in a small group, usually every
                pair).
            size (int):
     """

    members: list[DuplicateMember]
    number: int
    pairs: list[DuplicatePair]
    size: int
    additional_properties: dict[str, Any] = _attrs_field(init=False, factory=dict)





    def to_dict(self) -> dict[str, Any]:
        from ..models.duplicate_member import DuplicateMember # noqa: PLC0415
        from ..models.duplicate_pair import DuplicatePair # noqa: PLC0415
        members = []
        for members_item_data in self.members:
            members_item = members_item_data.to_dict()
            members.append(members_item)



        number = self.number

        pairs = []
        for pairs_item_data in self.pairs:
            pairs_item = pairs_item_data.to_dict()
            pairs.append(pairs_item)



        size = self.size


        field_dict: dict[str, Any] = {}
        field_dict.update(self.additional_properties)
        field_dict.update({
            "members": members,
            "number": number,
            "pairs": pairs,
            "size": size,
        })

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        from ..models.duplicate_member import DuplicateMember # noqa: PLC0415
        from ..models.duplicate_pair import DuplicatePair # noqa: PLC0415
        d = dict(src_dict)
        members = []
        _members = d.pop("members")
        for members_item_data in (_members):
            members_item = DuplicateMember.from_dict(members_item_data)



            members.append(members_item)


        number = d.pop("number")

        pairs = []
        _pairs = d.pop("pairs")
        for pairs_item_data in (_pairs):
            pairs_item = DuplicatePair.from_dict(pairs_item_data)



            pairs.append(pairs_item)


        size = d.pop("size")

        duplicate_group_resource = cls(
            members=members,
            number=number,
            pairs=pairs,
            size=size,
        )


        duplicate_group_resource.additional_properties = d
        return duplicate_group_resource

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
