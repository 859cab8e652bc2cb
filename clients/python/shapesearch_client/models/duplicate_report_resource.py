from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from typing import cast
from uuid import UUID
import datetime

if TYPE_CHECKING:
  from ..models.duplicate_group_resource import DuplicateGroupResource





T = TypeVar("T", bound="DuplicateReportResource")



@_attrs_define
class DuplicateReportResource:
    """ 
        Attributes:
            computed_at (datetime.datetime):
            descriptor_version (str):
            exact (bool): true: every pair of models was compared (up to SHAPESEARCH_INDEX_EXACT_MAX models); false: each
                model with those of the index's SHAPESEARCH_INDEX_NPROBE inverted lists nearest its own (scores stay exact).
            group_count (int): Groups in the whole report.
            groups (list[DuplicateGroupResource]): Largest groups first.
            id (UUID):
            job_id (None | UUID): The job that computed it; null when `shapesearch duplicates` did.
            min_score (float):
            models (int): Ready models compared.
            next_cursor (None | str): Pass as `cursor` for the next page of this report; null: last.
            size_tolerance (float | None): As asked: null groups parts of any size (families), a number parts of the same
                size.
            stale (bool): Models of the tenant became ready, were re-described or were deleted since computed_at: POST again
                for a report of the current models.
     """

    computed_at: datetime.datetime
    descriptor_version: str
    exact: bool
    group_count: int
    groups: list[DuplicateGroupResource]
    id: UUID
    job_id: None | UUID
    min_score: float
    models: int
    next_cursor: None | str
    size_tolerance: float | None
    stale: bool
    additional_properties: dict[str, Any] = _attrs_field(init=False, factory=dict)





    def to_dict(self) -> dict[str, Any]:
        from ..models.duplicate_group_resource import DuplicateGroupResource # noqa: PLC0415
        computed_at = self.computed_at.isoformat()

        descriptor_version = self.descriptor_version

        exact = self.exact

        group_count = self.group_count

        groups = []
        for groups_item_data in self.groups:
            groups_item = groups_item_data.to_dict()
            groups.append(groups_item)



        id = str(self.id)

        job_id: None | str
        if isinstance(self.job_id, UUID):
            job_id = str(self.job_id)
        else:
            job_id = self.job_id

        min_score = self.min_score

        models = self.models

        next_cursor: None | str
        next_cursor = self.next_cursor

        size_tolerance: float | None
        size_tolerance = self.size_tolerance

        stale = self.stale


        field_dict: dict[str, Any] = {}
        field_dict.update(self.additional_properties)
        field_dict.update({
            "computed_at": computed_at,
            "descriptor_version": descriptor_version,
            "exact": exact,
            "group_count": group_count,
            "groups": groups,
            "id": id,
            "job_id": job_id,
            "min_score": min_score,
            "models": models,
            "next_cursor": next_cursor,
            "size_tolerance": size_tolerance,
            "stale": stale,
        })

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        from ..models.duplicate_group_resource import DuplicateGroupResource # noqa: PLC0415
        d = dict(src_dict)
        computed_at = datetime.datetime.fromisoformat(d.pop("computed_at"))




        descriptor_version = d.pop("descriptor_version")

        exact = d.pop("exact")

        group_count = d.pop("group_count")

        groups = []
        _groups = d.pop("groups")
        for groups_item_data in (_groups):
            groups_item = DuplicateGroupResource.from_dict(groups_item_data)



            groups.append(groups_item)


        id = UUID(d.pop("id"))




        def _parse_job_id(data: object) -> None | UUID:
            if data is None:
                return data
            try:
                if not isinstance(data, str):
                    raise TypeError()
                job_id_type_0 = UUID(data)



                return job_id_type_0
            except (TypeError, ValueError, AttributeError, KeyError):
                pass
            return cast(None | UUID, data)

        job_id = _parse_job_id(d.pop("job_id"))


        min_score = d.pop("min_score")

        models = d.pop("models")

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


        stale = d.pop("stale")

        duplicate_report_resource = cls(
            computed_at=computed_at,
            descriptor_version=descriptor_version,
            exact=exact,
            group_count=group_count,
            groups=groups,
            id=id,
            job_id=job_id,
            min_score=min_score,
            models=models,
            next_cursor=next_cursor,
            size_tolerance=size_tolerance,
            stale=stale,
        )


        duplicate_report_resource.additional_properties = d
        return duplicate_report_resource

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
