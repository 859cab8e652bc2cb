from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from typing import cast
from uuid import UUID






T = TypeVar("T", bound="PartPointsResponse")



@_attrs_define
class PartPointsResponse:
    """ 
        Attributes:
            assembly_id (UUID):
            labels (list[int]): Per point, the index in `part_ids` of the part it lies on (its own points placed at every
                placement, the nearest); -1: on none known (a part not described yet).
            part_ids (list[UUID]): The assembly's parts, as `GET /v1/models/{id}/parts` lists them.
            points (list[list[float]]): Points on the whole assembly, x y z in its file's coordinates (the stored sample of
                its describe, evenly thinned to at most `points`).
     """

    assembly_id: UUID
    labels: list[int]
    part_ids: list[UUID]
    points: list[list[float]]
    additional_properties: dict[str, Any] = _attrs_field(init=False, factory=dict)





    def to_dict(self) -> dict[str, Any]:
        assembly_id = str(self.assembly_id)

        labels = self.labels



        part_ids = []
        for part_ids_item_data in self.part_ids:
            part_ids_item = str(part_ids_item_data)
            part_ids.append(part_ids_item)



        points = []
        for points_item_data in self.points:
            points_item = points_item_data


            points.append(points_item)




        field_dict: dict[str, Any] = {}
        field_dict.update(self.additional_properties)
        field_dict.update({
            "assembly_id": assembly_id,
            "labels": labels,
            "part_ids": part_ids,
            "points": points,
        })

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        d = dict(src_dict)
        assembly_id = UUID(d.pop("assembly_id"))




        labels = cast(list[int], d.pop("labels"))


        part_ids = []
        _part_ids = d.pop("part_ids")
        for part_ids_item_data in (_part_ids):
            part_ids_item = UUID(part_ids_item_data)



            part_ids.append(part_ids_item)


        points = []
        _points = d.pop("points")
        for points_item_data in (_points):
            points_item = cast(list[float], points_item_data)

            points.append(points_item)


        part_points_response = cls(
            assembly_id=assembly_id,
            labels=labels,
            part_ids=part_ids,
            points=points,
        )


        part_points_response.additional_properties = d
        return part_points_response

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
