from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from ..models.size_units_type_0 import SizeUnitsType0
from typing import cast






T = TypeVar("T", bound="Size")



@_attrs_define
class Size:
    """ A model's size in the units of its file (``units``; null: not declared, compared as
    given): the sorted extents of its minimum-volume oriented bounding box, its surface
    area, and the volume it encloses when it is a watertight mesh (null otherwise).

        Attributes:
            area (float):
            height (float):
            length (float):
            units (None | SizeUnitsType0):
            volume (float | None):
            width (float):
     """

    area: float
    height: float
    length: float
    units: None | SizeUnitsType0
    volume: float | None
    width: float
    additional_properties: dict[str, Any] = _attrs_field(init=False, factory=dict)





    def to_dict(self) -> dict[str, Any]:
        area = self.area

        height = self.height

        length = self.length

        units: None | str
        if isinstance(self.units, SizeUnitsType0):
            units = self.units.value
        else:
            units = self.units

        volume: float | None
        volume = self.volume

        width = self.width


        field_dict: dict[str, Any] = {}
        field_dict.update(self.additional_properties)
        field_dict.update({
            "area": area,
            "height": height,
            "length": length,
            "units": units,
            "volume": volume,
            "width": width,
        })

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        d = dict(src_dict)
        area = d.pop("area")

        height = d.pop("height")

        length = d.pop("length")

        def _parse_units(data: object) -> None | SizeUnitsType0:
            if data is None:
                return data
            try:
                if not isinstance(data, str):
                    raise TypeError()
                units_type_0 = SizeUnitsType0(data)



                return units_type_0
            except (TypeError, ValueError, AttributeError, KeyError):
                pass
            return cast(None | SizeUnitsType0, data)

        units = _parse_units(d.pop("units"))


        def _parse_volume(data: object) -> float | None:
            if data is None:
                return data
            return cast(float | None, data)

        volume = _parse_volume(d.pop("volume"))


        width = d.pop("width")

        size = cls(
            area=area,
            height=height,
            length=length,
            units=units,
            volume=volume,
            width=width,
        )


        size.additional_properties = d
        return size

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
