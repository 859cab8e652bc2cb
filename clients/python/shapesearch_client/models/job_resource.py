from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from ..models.job_resource_kind import JobResourceKind
from ..models.job_resource_status import JobResourceStatus
from typing import cast
from uuid import UUID
import datetime

if TYPE_CHECKING:
  from ..models.model_error import ModelError





T = TypeVar("T", bound="JobResource")



@_attrs_define
class JobResource:
    """ 
        Attributes:
            attempts (int):
            background (bool): Part of a bulk load (an upload sent with background=true) or of a catalogue's re-describe: it
                takes turns with the tenant's other jobs instead of holding them up.
            created_at (datetime.datetime):
            id (UUID):
            kind (JobResourceKind): describe: a new model's file; redescribe: a model's stored or new file again;
                duplicates: the tenant's duplicates report (GET /v1/duplicates once done).
            last_error (ModelError | None):
            leased_until (datetime.datetime | None):
            model_id (None | UUID): The model described; null for a duplicates job.
            status (JobResourceStatus):
            updated_at (datetime.datetime):
     """

    attempts: int
    background: bool
    created_at: datetime.datetime
    id: UUID
    kind: JobResourceKind
    last_error: ModelError | None
    leased_until: datetime.datetime | None
    model_id: None | UUID
    status: JobResourceStatus
    updated_at: datetime.datetime
    additional_properties: dict[str, Any] = _attrs_field(init=False, factory=dict)





    def to_dict(self) -> dict[str, Any]:
        from ..models.model_error import ModelError # noqa: PLC0415
        attempts = self.attempts

        background = self.background

        created_at = self.created_at.isoformat()

        id = str(self.id)

        kind = self.kind.value

        last_error: dict[str, Any] | None
        if isinstance(self.last_error, ModelError):
            last_error = self.last_error.to_dict()
        else:
            last_error = self.last_error

        leased_until: None | str
        if isinstance(self.leased_until, datetime.datetime):
            leased_until = self.leased_until.isoformat()
        else:
            leased_until = self.leased_until

        model_id: None | str
        if isinstance(self.model_id, UUID):
            model_id = str(self.model_id)
        else:
            model_id = self.model_id

        status = self.status.value

        updated_at = self.updated_at.isoformat()


        field_dict: dict[str, Any] = {}
        field_dict.update(self.additional_properties)
        field_dict.update({
            "attempts": attempts,
            "background": background,
            "created_at": created_at,
            "id": id,
            "kind": kind,
            "last_error": last_error,
            "leased_until": leased_until,
            "model_id": model_id,
            "status": status,
            "updated_at": updated_at,
        })

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        from ..models.model_error import ModelError # noqa: PLC0415
        d = dict(src_dict)
        attempts = d.pop("attempts")

        background = d.pop("background")

        created_at = datetime.datetime.fromisoformat(d.pop("created_at"))




        id = UUID(d.pop("id"))




        kind = JobResourceKind(d.pop("kind"))




        def _parse_last_error(data: object) -> ModelError | None:
            if data is None:
                return data
            try:
                if not isinstance(data, dict):
                    raise TypeError()
                last_error_type_0 = ModelError.from_dict(data)



                return last_error_type_0
            except (TypeError, ValueError, AttributeError, KeyError):
                pass
            return cast(ModelError | None, data)

        last_error = _parse_last_error(d.pop("last_error"))


        def _parse_leased_until(data: object) -> datetime.datetime | None:
            if data is None:
                return data
            try:
                if not isinstance(data, str):
                    raise TypeError()
                leased_until_type_0 = datetime.datetime.fromisoformat(data)



                return leased_until_type_0
            except (TypeError, ValueError, AttributeError, KeyError):
                pass
            return cast(datetime.datetime | None, data)

        leased_until = _parse_leased_until(d.pop("leased_until"))


        def _parse_model_id(data: object) -> None | UUID:
            if data is None:
                return data
            try:
                if not isinstance(data, str):
                    raise TypeError()
                model_id_type_0 = UUID(data)



                return model_id_type_0
            except (TypeError, ValueError, AttributeError, KeyError):
                pass
            return cast(None | UUID, data)

        model_id = _parse_model_id(d.pop("model_id"))


        status = JobResourceStatus(d.pop("status"))




        updated_at = datetime.datetime.fromisoformat(d.pop("updated_at"))




        job_resource = cls(
            attempts=attempts,
            background=background,
            created_at=created_at,
            id=id,
            kind=kind,
            last_error=last_error,
            leased_until=leased_until,
            model_id=model_id,
            status=status,
            updated_at=updated_at,
        )


        job_resource.additional_properties = d
        return job_resource

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
