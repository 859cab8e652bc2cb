from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from typing import cast






T = TypeVar("T", bound="AlignmentRecord")



@_attrs_define
class AlignmentRecord:
    """ A rigid placement (with a uniform scale) of one point set on another: a point ``p``
    of the placed part lands at ``scale * rotation @ p + translation``.

        Attributes:
            candidates (int): Starts tried: the principal frames' ambiguities (and, for a scan, the views of the part), each
                refined by ICP; the best result is kept.
            rotation (list[list[float]]): 3 x 3, row-major, a proper rotation (determinant +1).
            scale (float): 1 unless a scale was asked for (or, for a scan, found: the scan's units are unknown).
            translation (list[float]): 3 numbers, in the reference's units.
     """

    candidates: int
    rotation: list[list[float]]
    scale: float
    translation: list[float]
    additional_properties: dict[str, Any] = _attrs_field(init=False, factory=dict)





    def to_dict(self) -> dict[str, Any]:
        candidates = self.candidates

        rotation = []
        for rotation_item_data in self.rotation:
            rotation_item = rotation_item_data


            rotation.append(rotation_item)



        scale = self.scale

        translation = self.translation




        field_dict: dict[str, Any] = {}
        field_dict.update(self.additional_properties)
        field_dict.update({
            "candidates": candidates,
            "rotation": rotation,
            "scale": scale,
            "translation": translation,
        })

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        d = dict(src_dict)
        candidates = d.pop("candidates")

        rotation = []
        _rotation = d.pop("rotation")
        for rotation_item_data in (_rotation):
            rotation_item = cast(list[float], rotation_item_data)

            rotation.append(rotation_item)


        scale = d.pop("scale")

        translation = cast(list[float], d.pop("translation"))


        alignment_record = cls(
            candidates=candidates,
            rotation=rotation,
            scale=scale,
            translation=translation,
        )


        alignment_record.additional_properties = d
        return alignment_record

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
