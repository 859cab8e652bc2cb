from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from ..types import UNSET, Unset
from typing import cast

if TYPE_CHECKING:
  from ..models.duplicate_member import DuplicateMember
  from ..models.duplicate_pair import DuplicatePair
  from ..models.where_used_entry import WhereUsedEntry





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
            where_used (list[WhereUsedEntry] | None | Unset): With `where_used=true` only: the assemblies that place any
                member of the group, oldest first, with the members' placements counted and the members placed (`parts`). Two or
                more: the same part used across assemblies.
     """

    members: list[DuplicateMember]
    number: int
    pairs: list[DuplicatePair]
    size: int
    where_used: list[WhereUsedEntry] | None | Unset = UNSET
    additional_properties: dict[str, Any] = _attrs_field(init=False, factory=dict)





    def to_dict(self) -> dict[str, Any]:
        from ..models.duplicate_member import DuplicateMember # noqa: PLC0415
        from ..models.duplicate_pair import DuplicatePair # noqa: PLC0415
        from ..models.where_used_entry import WhereUsedEntry # noqa: PLC0415
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

        where_used: list[dict[str, Any]] | None | Unset
        if isinstance(self.where_used, Unset):
            where_used = UNSET
        elif isinstance(self.where_used, list):
            where_used = []
            for where_used_type_0_item_data in self.where_used:
                where_used_type_0_item = where_used_type_0_item_data.to_dict()
                where_used.append(where_used_type_0_item)


        else:
            where_used = self.where_used


        field_dict: dict[str, Any] = {}
        field_dict.update(self.additional_properties)
        field_dict.update({
            "members": members,
            "number": number,
            "pairs": pairs,
            "size": size,
        })
        if where_used is not UNSET:
            field_dict["where_used"] = where_used

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        from ..models.duplicate_member import DuplicateMember # noqa: PLC0415
        from ..models.duplicate_pair import DuplicatePair # noqa: PLC0415
        from ..models.where_used_entry import WhereUsedEntry # noqa: PLC0415
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

        def _parse_where_used(data: object) -> list[WhereUsedEntry] | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            try:
                if not isinstance(data, list):
                    raise TypeError()
                where_used_type_0 = []
                _where_used_type_0 = data
                for where_used_type_0_item_data in (_where_used_type_0):
                    where_used_type_0_item = WhereUsedEntry.from_dict(where_used_type_0_item_data)



                    where_used_type_0.append(where_used_type_0_item)

                return where_used_type_0
            except (TypeError, ValueError, AttributeError, KeyError):
                pass
            return cast(list[WhereUsedEntry] | None | Unset, data)

        where_used = _parse_where_used(d.pop("where_used", UNSET))


        duplicate_group_resource = cls(
            members=members,
            number=number,
            pairs=pairs,
            size=size,
            where_used=where_used,
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
