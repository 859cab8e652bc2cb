from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from ..types import UNSET, Unset
from typing import cast






T = TypeVar("T", bound="DuplicatesRequest")



@_attrs_define
class DuplicatesRequest:
    """ 
        Attributes:
            descriptor_version (None | str | Unset): Default: the service's current one.
            min_score (float | Unset):  Default: 0.98.
            size_tolerance (float | None | Unset): Same size too: every extent within this relative tolerance (models
                without a size then group with none); null: any size.
     """

    descriptor_version: None | str | Unset = UNSET
    min_score: float | Unset = 0.98
    size_tolerance: float | None | Unset = UNSET





    def to_dict(self) -> dict[str, Any]:
        descriptor_version: None | str | Unset
        if isinstance(self.descriptor_version, Unset):
            descriptor_version = UNSET
        else:
            descriptor_version = self.descriptor_version

        min_score = self.min_score

        size_tolerance: float | None | Unset
        if isinstance(self.size_tolerance, Unset):
            size_tolerance = UNSET
        else:
            size_tolerance = self.size_tolerance


        field_dict: dict[str, Any] = {}

        field_dict.update({
        })
        if descriptor_version is not UNSET:
            field_dict["descriptor_version"] = descriptor_version
        if min_score is not UNSET:
            field_dict["min_score"] = min_score
        if size_tolerance is not UNSET:
            field_dict["size_tolerance"] = size_tolerance

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        d = dict(src_dict)
        def _parse_descriptor_version(data: object) -> None | str | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(None | str | Unset, data)

        descriptor_version = _parse_descriptor_version(d.pop("descriptor_version", UNSET))


        min_score = d.pop("min_score", UNSET)

        def _parse_size_tolerance(data: object) -> float | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(float | None | Unset, data)

        size_tolerance = _parse_size_tolerance(d.pop("size_tolerance", UNSET))


        duplicates_request = cls(
            descriptor_version=descriptor_version,
            min_score=min_score,
            size_tolerance=size_tolerance,
        )

        return duplicates_request

