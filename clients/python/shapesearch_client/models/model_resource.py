from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from ..models.model_resource_status import ModelResourceStatus
from ..types import UNSET, Unset
from typing import cast
from uuid import UUID
import datetime

if TYPE_CHECKING:
  from ..models.cutoff_record import CutoffRecord
  from ..models.file_info import FileInfo
  from ..models.job_summary import JobSummary
  from ..models.model_error import ModelError
  from ..models.model_resource_metadata import ModelResourceMetadata
  from ..models.model_resource_timings_type_0 import ModelResourceTimingsType0
  from ..models.size import Size





T = TypeVar("T", bound="ModelResource")



@_attrs_define
class ModelResource:
    """ 
        Attributes:
            created_at (datetime.datetime):
            cutoff (CutoffRecord | None):
            descriptor_version (None | str):
            error (ModelError | None):
            external_id (None | str):
            file (FileInfo):
            id (UUID):
            metadata (ModelResourceMetadata):
            n_points (int | None):
            name (None | str):
            size (None | Size): Null until described (and for models described before sizes were measured: re-describe
                them).
            status (ModelResourceStatus):
            timings (ModelResourceTimingsType0 | None): Seconds per stage of the description.
            updated_at (datetime.datetime):
            job (JobSummary | None | Unset): The model's latest job.
     """

    created_at: datetime.datetime
    cutoff: CutoffRecord | None
    descriptor_version: None | str
    error: ModelError | None
    external_id: None | str
    file: FileInfo
    id: UUID
    metadata: ModelResourceMetadata
    n_points: int | None
    name: None | str
    size: None | Size
    status: ModelResourceStatus
    timings: ModelResourceTimingsType0 | None
    updated_at: datetime.datetime
    job: JobSummary | None | Unset = UNSET
    additional_properties: dict[str, Any] = _attrs_field(init=False, factory=dict)





    def to_dict(self) -> dict[str, Any]:
        from ..models.cutoff_record import CutoffRecord # noqa: PLC0415
        from ..models.file_info import FileInfo # noqa: PLC0415
        from ..models.job_summary import JobSummary # noqa: PLC0415
        from ..models.model_error import ModelError # noqa: PLC0415
        from ..models.model_resource_metadata import ModelResourceMetadata # noqa: PLC0415
        from ..models.model_resource_timings_type_0 import ModelResourceTimingsType0 # noqa: PLC0415
        from ..models.size import Size # noqa: PLC0415
        created_at = self.created_at.isoformat()

        cutoff: dict[str, Any] | None
        if isinstance(self.cutoff, CutoffRecord):
            cutoff = self.cutoff.to_dict()
        else:
            cutoff = self.cutoff

        descriptor_version: None | str
        descriptor_version = self.descriptor_version

        error: dict[str, Any] | None
        if isinstance(self.error, ModelError):
            error = self.error.to_dict()
        else:
            error = self.error

        external_id: None | str
        external_id = self.external_id

        file = self.file.to_dict()

        id = str(self.id)

        metadata = self.metadata.to_dict()

        n_points: int | None
        n_points = self.n_points

        name: None | str
        name = self.name

        size: dict[str, Any] | None
        if isinstance(self.size, Size):
            size = self.size.to_dict()
        else:
            size = self.size

        status = self.status.value

        timings: dict[str, Any] | None
        if isinstance(self.timings, ModelResourceTimingsType0):
            timings = self.timings.to_dict()
        else:
            timings = self.timings

        updated_at = self.updated_at.isoformat()

        job: dict[str, Any] | None | Unset
        if isinstance(self.job, Unset):
            job = UNSET
        elif isinstance(self.job, JobSummary):
            job = self.job.to_dict()
        else:
            job = self.job


        field_dict: dict[str, Any] = {}
        field_dict.update(self.additional_properties)
        field_dict.update({
            "created_at": created_at,
            "cutoff": cutoff,
            "descriptor_version": descriptor_version,
            "error": error,
            "external_id": external_id,
            "file": file,
            "id": id,
            "metadata": metadata,
            "n_points": n_points,
            "name": name,
            "size": size,
            "status": status,
            "timings": timings,
            "updated_at": updated_at,
        })
        if job is not UNSET:
            field_dict["job"] = job

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        from ..models.cutoff_record import CutoffRecord # noqa: PLC0415
        from ..models.file_info import FileInfo # noqa: PLC0415
        from ..models.job_summary import JobSummary # noqa: PLC0415
        from ..models.model_error import ModelError # noqa: PLC0415
        from ..models.model_resource_metadata import ModelResourceMetadata # noqa: PLC0415
        from ..models.model_resource_timings_type_0 import ModelResourceTimingsType0 # noqa: PLC0415
        from ..models.size import Size # noqa: PLC0415
        d = dict(src_dict)
        created_at = datetime.datetime.fromisoformat(d.pop("created_at"))




        def _parse_cutoff(data: object) -> CutoffRecord | None:
            if data is None:
                return data
            try:
                if not isinstance(data, dict):
                    raise TypeError()
                cutoff_type_0 = CutoffRecord.from_dict(data)



                return cutoff_type_0
            except (TypeError, ValueError, AttributeError, KeyError):
                pass
            return cast(CutoffRecord | None, data)

        cutoff = _parse_cutoff(d.pop("cutoff"))


        def _parse_descriptor_version(data: object) -> None | str:
            if data is None:
                return data
            return cast(None | str, data)

        descriptor_version = _parse_descriptor_version(d.pop("descriptor_version"))


        def _parse_error(data: object) -> ModelError | None:
            if data is None:
                return data
            try:
                if not isinstance(data, dict):
                    raise TypeError()
                error_type_0 = ModelError.from_dict(data)



                return error_type_0
            except (TypeError, ValueError, AttributeError, KeyError):
                pass
            return cast(ModelError | None, data)

        error = _parse_error(d.pop("error"))


        def _parse_external_id(data: object) -> None | str:
            if data is None:
                return data
            return cast(None | str, data)

        external_id = _parse_external_id(d.pop("external_id"))


        file = FileInfo.from_dict(d.pop("file"))




        id = UUID(d.pop("id"))




        metadata = ModelResourceMetadata.from_dict(d.pop("metadata"))




        def _parse_n_points(data: object) -> int | None:
            if data is None:
                return data
            return cast(int | None, data)

        n_points = _parse_n_points(d.pop("n_points"))


        def _parse_name(data: object) -> None | str:
            if data is None:
                return data
            return cast(None | str, data)

        name = _parse_name(d.pop("name"))


        def _parse_size(data: object) -> None | Size:
            if data is None:
                return data
            try:
                if not isinstance(data, dict):
                    raise TypeError()
                size_type_0 = Size.from_dict(data)



                return size_type_0
            except (TypeError, ValueError, AttributeError, KeyError):
                pass
            return cast(None | Size, data)

        size = _parse_size(d.pop("size"))


        status = ModelResourceStatus(d.pop("status"))




        def _parse_timings(data: object) -> ModelResourceTimingsType0 | None:
            if data is None:
                return data
            try:
                if not isinstance(data, dict):
                    raise TypeError()
                timings_type_0 = ModelResourceTimingsType0.from_dict(data)



                return timings_type_0
            except (TypeError, ValueError, AttributeError, KeyError):
                pass
            return cast(ModelResourceTimingsType0 | None, data)

        timings = _parse_timings(d.pop("timings"))


        updated_at = datetime.datetime.fromisoformat(d.pop("updated_at"))




        def _parse_job(data: object) -> JobSummary | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            try:
                if not isinstance(data, dict):
                    raise TypeError()
                job_type_0 = JobSummary.from_dict(data)



                return job_type_0
            except (TypeError, ValueError, AttributeError, KeyError):
                pass
            return cast(JobSummary | None | Unset, data)

        job = _parse_job(d.pop("job", UNSET))


        model_resource = cls(
            created_at=created_at,
            cutoff=cutoff,
            descriptor_version=descriptor_version,
            error=error,
            external_id=external_id,
            file=file,
            id=id,
            metadata=metadata,
            n_points=n_points,
            name=name,
            size=size,
            status=status,
            timings=timings,
            updated_at=updated_at,
            job=job,
        )


        model_resource.additional_properties = d
        return model_resource

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
