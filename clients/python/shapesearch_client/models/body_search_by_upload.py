from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field
import json
from .. import types

from ..types import UNSET, Unset

from ..models.body_search_by_upload_units import BodySearchByUploadUnits
from ..types import File, FileTypes
from ..types import UNSET, Unset
from io import BytesIO






T = TypeVar("T", bound="BodySearchByUpload")



@_attrs_define
class BodySearchByUpload:
    """ 
        Attributes:
            file (File): Mesh, point cloud, scanner or CAD file; its name's extension tells the format: stl, obj, off, ply,
                glb, gltf, 3mf, xyz, txt, csv, pts, pcd, npy, e57, las, laz, step, iges (stp and igs too).
            units (BodySearchByUploadUnits | Unset): Units of the file's coordinates: mm, cm, m or in. Sizes compare in
                millimetres where units are known; without, the numbers are compared as given.
     """

    file: File
    units: BodySearchByUploadUnits | Unset = UNSET
    additional_properties: dict[str, Any] = _attrs_field(init=False, factory=dict)





    def to_dict(self) -> dict[str, Any]:
        file = self.file.to_tuple()


        units: str | Unset = UNSET
        if not isinstance(self.units, Unset):
            units = self.units.value



        field_dict: dict[str, Any] = {}
        field_dict.update(self.additional_properties)
        field_dict.update({
            "file": file,
        })
        if units is not UNSET:
            field_dict["units"] = units

        return field_dict


    def to_multipart(self) -> types.RequestFiles:
        files: types.RequestFiles = []

        files.append(("file", self.file.to_tuple()))



        if not isinstance(self.units, Unset):
            files.append(("units",  (None, str(self.units.value).encode(), "text/plain")))




        for prop_name, prop in self.additional_properties.items():
            files.append((prop_name, (None, str(prop).encode(), "text/plain")))



        return files


    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        d = dict(src_dict)
        file = File(
             payload = BytesIO(d.pop("file"))
        )




        _units = d.pop("units", UNSET)
        units: BodySearchByUploadUnits | Unset
        if isinstance(_units,  Unset):
            units = UNSET
        else:
            units = BodySearchByUploadUnits(_units)




        body_search_by_upload = cls(
            file=file,
            units=units,
        )


        body_search_by_upload.additional_properties = d
        return body_search_by_upload

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
