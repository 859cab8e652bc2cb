from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from ..types import UNSET, Unset
from typing import cast

if TYPE_CHECKING:
  from ..models.problem_checks import ProblemChecks
  from ..models.problem_errors_item import ProblemErrorsItem





T = TypeVar("T", bound="Problem")



@_attrs_define
class Problem:
    """ RFC 9457 problem details; a kind's extension members (pointer, errors, reason, existing_id, model_status, checks)
    come next to these.

        Attributes:
            detail (str):
            status (int):
            title (str): The kind's title (one per type).
            type_ (str): urn:shapesearch:problem:<kind>, or about:blank when the status says it all.
            checks (ProblemChecks | Unset): not-ready: every readiness check's state.
            errors (list[ProblemErrorsItem] | Unset): validation-error: every refused field.
            existing_id (str | Unset): duplicate-external-id: the model that holds the external id.
            limit (int | Unset): too-large: the limit, in bytes.
            model_status (str | Unset): model-not-ready: its status.
            pointer (str | Unset): validation-error: a JSON pointer to the refused field (/query/k, /metadata/a).
            reason (str | Unset): A refused shape file: the engine's reason code (too_few_points, degenerate, ...).
     """

    detail: str
    status: int
    title: str
    type_: str
    checks: ProblemChecks | Unset = UNSET
    errors: list[ProblemErrorsItem] | Unset = UNSET
    existing_id: str | Unset = UNSET
    limit: int | Unset = UNSET
    model_status: str | Unset = UNSET
    pointer: str | Unset = UNSET
    reason: str | Unset = UNSET
    additional_properties: dict[str, Any] = _attrs_field(init=False, factory=dict)





    def to_dict(self) -> dict[str, Any]:
        from ..models.problem_checks import ProblemChecks # noqa: PLC0415
        from ..models.problem_errors_item import ProblemErrorsItem # noqa: PLC0415
        detail = self.detail

        status = self.status

        title = self.title

        type_ = self.type_

        checks: dict[str, Any] | Unset = UNSET
        if not isinstance(self.checks, Unset):
            checks = self.checks.to_dict()

        errors: list[dict[str, Any]] | Unset = UNSET
        if not isinstance(self.errors, Unset):
            errors = []
            for errors_item_data in self.errors:
                errors_item = errors_item_data.to_dict()
                errors.append(errors_item)



        existing_id = self.existing_id

        limit = self.limit

        model_status = self.model_status

        pointer = self.pointer

        reason = self.reason


        field_dict: dict[str, Any] = {}
        field_dict.update(self.additional_properties)
        field_dict.update({
            "detail": detail,
            "status": status,
            "title": title,
            "type": type_,
        })
        if checks is not UNSET:
            field_dict["checks"] = checks
        if errors is not UNSET:
            field_dict["errors"] = errors
        if existing_id is not UNSET:
            field_dict["existing_id"] = existing_id
        if limit is not UNSET:
            field_dict["limit"] = limit
        if model_status is not UNSET:
            field_dict["model_status"] = model_status
        if pointer is not UNSET:
            field_dict["pointer"] = pointer
        if reason is not UNSET:
            field_dict["reason"] = reason

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        from ..models.problem_checks import ProblemChecks # noqa: PLC0415
        from ..models.problem_errors_item import ProblemErrorsItem # noqa: PLC0415
        d = dict(src_dict)
        detail = d.pop("detail")

        status = d.pop("status")

        title = d.pop("title")

        type_ = d.pop("type")

        _checks = d.pop("checks", UNSET)
        checks: ProblemChecks | Unset
        if isinstance(_checks,  Unset):
            checks = UNSET
        else:
            checks = ProblemChecks.from_dict(_checks)




        _errors = d.pop("errors", UNSET)
        errors: list[ProblemErrorsItem] | Unset = UNSET
        if _errors is not UNSET:
            errors = []
            for errors_item_data in _errors:
                errors_item = ProblemErrorsItem.from_dict(errors_item_data)



                errors.append(errors_item)


        existing_id = d.pop("existing_id", UNSET)

        limit = d.pop("limit", UNSET)

        model_status = d.pop("model_status", UNSET)

        pointer = d.pop("pointer", UNSET)

        reason = d.pop("reason", UNSET)

        problem = cls(
            detail=detail,
            status=status,
            title=title,
            type_=type_,
            checks=checks,
            errors=errors,
            existing_id=existing_id,
            limit=limit,
            model_status=model_status,
            pointer=pointer,
            reason=reason,
        )


        problem.additional_properties = d
        return problem

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
