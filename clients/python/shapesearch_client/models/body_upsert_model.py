from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field
import json
from .. import types

from ..types import UNSET, Unset

from ..models.body_upsert_model_assembly import BodyUpsertModelAssembly
from ..models.body_upsert_model_units import BodyUpsertModelUnits
from ..types import File, FileTypes
from ..types import UNSET, Unset
from io import BytesIO
from typing import cast

if TYPE_CHECKING:
  from ..models.body_upsert_model_metadata import BodyUpsertModelMetadata





T = TypeVar("T", bound="BodyUpsertModel")



@_attrs_define
class BodyUpsertModel:
    """ 
        Attributes:
            file (File): Mesh, point cloud, scanner or CAD file; its name's extension tells the format: stl, obj, off, ply,
                glb, gltf, 3mf, xyz, txt, csv, pts, pcd, npy, e57, las, laz, step, iges (stp and igs too).
            assembly (BodyUpsertModelAssembly | Unset): `split`: the file is an assembly (GLB, glTF, 3MF, OBJ: its geometry
                nodes; STEP or IGES: its solids); besides the model of the whole assembly, each distinct part becomes a model of
                its own, its instances counted and placed (`GET /v1/models/{id}/parts`). `whole`: one model. Absent:
                SHAPESEARCH_ASSEMBLY_DEFAULT (`whole` unless set; with `split`, a file that places one part once stays one
                model).
            background (bool | Unset): true for an upload that is part of a bulk load (`shapesearch import` sends it): its
                job takes turns with the tenant's other uploads instead of holding them up, as a catalogue's re-describe does.
                Scheduling only: the model and its descriptor are the same. Default: False.
            metadata (BodyUpsertModelMetadata | Unset): A JSON object, nested at most SHAPESEARCH_MAX_METADATA_DEPTH levels
                (default 8), at most SHAPESEARCH_MAX_METADATA_BYTES (default 16384) as compact JSON, its keys and strings
                without NUL at every level (else 422 validation-error pointing into it). Absent: the metadata stay as they are.
            name (str | Unset):
            units (BodyUpsertModelUnits | Unset): Units of the file's coordinates: mm, cm, m or in. Sizes compare in
                millimetres where units are known; without, the numbers are compared as given.
     """

    file: File
    assembly: BodyUpsertModelAssembly | Unset = UNSET
    background: bool | Unset = False
    metadata: BodyUpsertModelMetadata | Unset = UNSET
    name: str | Unset = UNSET
    units: BodyUpsertModelUnits | Unset = UNSET
    additional_properties: dict[str, Any] = _attrs_field(init=False, factory=dict)





    def to_dict(self) -> dict[str, Any]:
        from ..models.body_upsert_model_metadata import BodyUpsertModelMetadata # noqa: PLC0415
        file = self.file.to_tuple()


        assembly: str | Unset = UNSET
        if not isinstance(self.assembly, Unset):
            assembly = self.assembly.value


        background = self.background

        metadata: dict[str, Any] | Unset = UNSET
        if not isinstance(self.metadata, Unset):
            metadata = self.metadata.to_dict()

        name = self.name

        units: str | Unset = UNSET
        if not isinstance(self.units, Unset):
            units = self.units.value



        field_dict: dict[str, Any] = {}
        field_dict.update(self.additional_properties)
        field_dict.update({
            "file": file,
        })
        if assembly is not UNSET:
            field_dict["assembly"] = assembly
        if background is not UNSET:
            field_dict["background"] = background
        if metadata is not UNSET:
            field_dict["metadata"] = metadata
        if name is not UNSET:
            field_dict["name"] = name
        if units is not UNSET:
            field_dict["units"] = units

        return field_dict


    def to_multipart(self) -> types.RequestFiles:
        from ..models.body_upsert_model_metadata import BodyUpsertModelMetadata # noqa: PLC0415
        files: types.RequestFiles = []

        files.append(("file", self.file.to_tuple()))



        if not isinstance(self.assembly, Unset):
            files.append(("assembly",  (None, str(self.assembly.value).encode(), "text/plain")))



        if not isinstance(self.background, Unset):
            files.append(("background", (None, str(self.background).encode(), "text/plain")))



        if not isinstance(self.metadata, Unset):
            files.append(("metadata", (None, json.dumps( self.metadata.to_dict()).encode(), "application/json")))



        if not isinstance(self.name, Unset):
            files.append(("name", (None, str(self.name).encode(), "text/plain")))



        if not isinstance(self.units, Unset):
            files.append(("units",  (None, str(self.units.value).encode(), "text/plain")))




        for prop_name, prop in self.additional_properties.items():
            files.append((prop_name, (None, str(prop).encode(), "text/plain")))



        return files


    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        from ..models.body_upsert_model_metadata import BodyUpsertModelMetadata # noqa: PLC0415
        d = dict(src_dict)
        file = File(
             payload = BytesIO(d.pop("file"))
        )




        _assembly = d.pop("assembly", UNSET)
        assembly: BodyUpsertModelAssembly | Unset
        if isinstance(_assembly,  Unset):
            assembly = UNSET
        else:
            assembly = BodyUpsertModelAssembly(_assembly)




        background = d.pop("background", UNSET)

        _metadata = d.pop("metadata", UNSET)
        metadata: BodyUpsertModelMetadata | Unset
        if isinstance(_metadata,  Unset):
            metadata = UNSET
        else:
            metadata = BodyUpsertModelMetadata.from_dict(_metadata)




        name = d.pop("name", UNSET)

        _units = d.pop("units", UNSET)
        units: BodyUpsertModelUnits | Unset
        if isinstance(_units,  Unset):
            units = UNSET
        else:
            units = BodyUpsertModelUnits(_units)




        body_upsert_model = cls(
            file=file,
            assembly=assembly,
            background=background,
            metadata=metadata,
            name=name,
            units=units,
        )


        body_upsert_model.additional_properties = d
        return body_upsert_model

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
