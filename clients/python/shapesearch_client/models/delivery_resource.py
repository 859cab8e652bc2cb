from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from ..models.delivery_resource_event_type import DeliveryResourceEventType
from ..models.delivery_resource_status import DeliveryResourceStatus
from typing import cast
from uuid import UUID
import datetime

if TYPE_CHECKING:
  from ..models.attempt_resource import AttemptResource
  from ..models.delivery_resource_payload import DeliveryResourcePayload





T = TypeVar("T", bound="DeliveryResource")



@_attrs_define
class DeliveryResource:
    """ 
        Attributes:
            attempts (list[AttemptResource]):
            created_at (datetime.datetime):
            event_type (DeliveryResourceEventType):
            id (UUID): The webhook-id header, the same on every attempt.
            next_attempt_at (datetime.datetime | None):
            payload (DeliveryResourcePayload):
            status (DeliveryResourceStatus):
     """

    attempts: list[AttemptResource]
    created_at: datetime.datetime
    event_type: DeliveryResourceEventType
    id: UUID
    next_attempt_at: datetime.datetime | None
    payload: DeliveryResourcePayload
    status: DeliveryResourceStatus
    additional_properties: dict[str, Any] = _attrs_field(init=False, factory=dict)





    def to_dict(self) -> dict[str, Any]:
        from ..models.attempt_resource import AttemptResource # noqa: PLC0415
        from ..models.delivery_resource_payload import DeliveryResourcePayload # noqa: PLC0415
        attempts = []
        for attempts_item_data in self.attempts:
            attempts_item = attempts_item_data.to_dict()
            attempts.append(attempts_item)



        created_at = self.created_at.isoformat()

        event_type = self.event_type.value

        id = str(self.id)

        next_attempt_at: None | str
        if isinstance(self.next_attempt_at, datetime.datetime):
            next_attempt_at = self.next_attempt_at.isoformat()
        else:
            next_attempt_at = self.next_attempt_at

        payload = self.payload.to_dict()

        status = self.status.value


        field_dict: dict[str, Any] = {}
        field_dict.update(self.additional_properties)
        field_dict.update({
            "attempts": attempts,
            "created_at": created_at,
            "event_type": event_type,
            "id": id,
            "next_attempt_at": next_attempt_at,
            "payload": payload,
            "status": status,
        })

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        from ..models.attempt_resource import AttemptResource # noqa: PLC0415
        from ..models.delivery_resource_payload import DeliveryResourcePayload # noqa: PLC0415
        d = dict(src_dict)
        attempts = []
        _attempts = d.pop("attempts")
        for attempts_item_data in (_attempts):
            attempts_item = AttemptResource.from_dict(attempts_item_data)



            attempts.append(attempts_item)


        created_at = datetime.datetime.fromisoformat(d.pop("created_at"))




        event_type = DeliveryResourceEventType(d.pop("event_type"))




        id = UUID(d.pop("id"))




        def _parse_next_attempt_at(data: object) -> datetime.datetime | None:
            if data is None:
                return data
            try:
                if not isinstance(data, str):
                    raise TypeError()
                next_attempt_at_type_0 = datetime.datetime.fromisoformat(data)



                return next_attempt_at_type_0
            except (TypeError, ValueError, AttributeError, KeyError):
                pass
            return cast(datetime.datetime | None, data)

        next_attempt_at = _parse_next_attempt_at(d.pop("next_attempt_at"))


        payload = DeliveryResourcePayload.from_dict(d.pop("payload"))




        status = DeliveryResourceStatus(d.pop("status"))




        delivery_resource = cls(
            attempts=attempts,
            created_at=created_at,
            event_type=event_type,
            id=id,
            next_attempt_at=next_attempt_at,
            payload=payload,
            status=status,
        )


        delivery_resource.additional_properties = d
        return delivery_resource

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
