from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from typing import cast

if TYPE_CHECKING:
  from ..models.stats_by_descriptor_version import StatsByDescriptorVersion
  from ..models.stats_by_status import StatsByStatus
  from ..models.stats_engine_libraries import StatsEngineLibraries
  from ..models.stats_jobs_by_status import StatsJobsByStatus





T = TypeVar("T", bound="Stats")



@_attrs_define
class Stats:
    """ 
        Attributes:
            by_descriptor_version (StatsByDescriptorVersion): Ready models per descriptor_version; only
                current_descriptor_version is searched with POST /v1/search.
            by_status (StatsByStatus): Models per status.
            current_descriptor_version (str):
            engine_libraries (StatsEngineLibraries): This API process's versions of the libraries that can change a
                descriptor (numpy, scipy, trimesh, robust-laplacian, qdldl). They are part of current_descriptor_version: after
                an upgrade of one of them every stored model is from another version until it is re-described (shapesearch
                redescribe).
            jobs_by_status (StatsJobsByStatus):
            models (int):
            ready_without_size (int): Ready models described before sizes were measured: re-describe them (shapesearch
                redescribe --all) for size filters and size-aware ranking.
     """

    by_descriptor_version: StatsByDescriptorVersion
    by_status: StatsByStatus
    current_descriptor_version: str
    engine_libraries: StatsEngineLibraries
    jobs_by_status: StatsJobsByStatus
    models: int
    ready_without_size: int
    additional_properties: dict[str, Any] = _attrs_field(init=False, factory=dict)





    def to_dict(self) -> dict[str, Any]:
        from ..models.stats_by_descriptor_version import StatsByDescriptorVersion # noqa: PLC0415
        from ..models.stats_by_status import StatsByStatus # noqa: PLC0415
        from ..models.stats_engine_libraries import StatsEngineLibraries # noqa: PLC0415
        from ..models.stats_jobs_by_status import StatsJobsByStatus # noqa: PLC0415
        by_descriptor_version = self.by_descriptor_version.to_dict()

        by_status = self.by_status.to_dict()

        current_descriptor_version = self.current_descriptor_version

        engine_libraries = self.engine_libraries.to_dict()

        jobs_by_status = self.jobs_by_status.to_dict()

        models = self.models

        ready_without_size = self.ready_without_size


        field_dict: dict[str, Any] = {}
        field_dict.update(self.additional_properties)
        field_dict.update({
            "by_descriptor_version": by_descriptor_version,
            "by_status": by_status,
            "current_descriptor_version": current_descriptor_version,
            "engine_libraries": engine_libraries,
            "jobs_by_status": jobs_by_status,
            "models": models,
            "ready_without_size": ready_without_size,
        })

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        from ..models.stats_by_descriptor_version import StatsByDescriptorVersion # noqa: PLC0415
        from ..models.stats_by_status import StatsByStatus # noqa: PLC0415
        from ..models.stats_engine_libraries import StatsEngineLibraries # noqa: PLC0415
        from ..models.stats_jobs_by_status import StatsJobsByStatus # noqa: PLC0415
        d = dict(src_dict)
        by_descriptor_version = StatsByDescriptorVersion.from_dict(d.pop("by_descriptor_version"))




        by_status = StatsByStatus.from_dict(d.pop("by_status"))




        current_descriptor_version = d.pop("current_descriptor_version")

        engine_libraries = StatsEngineLibraries.from_dict(d.pop("engine_libraries"))




        jobs_by_status = StatsJobsByStatus.from_dict(d.pop("jobs_by_status"))




        models = d.pop("models")

        ready_without_size = d.pop("ready_without_size")

        stats = cls(
            by_descriptor_version=by_descriptor_version,
            by_status=by_status,
            current_descriptor_version=current_descriptor_version,
            engine_libraries=engine_libraries,
            jobs_by_status=jobs_by_status,
            models=models,
            ready_without_size=ready_without_size,
        )


        stats.additional_properties = d
        return stats

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
