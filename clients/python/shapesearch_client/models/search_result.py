from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from ..models.search_result_likeness_type_0 import SearchResultLikenessType0
from ..types import UNSET, Unset
from typing import cast

if TYPE_CHECKING:
  from ..models.explanation import Explanation
  from ..models.model_summary import ModelSummary
  from ..models.where_used_entry import WhereUsedEntry





T = TypeVar("T", bound="SearchResult")



@_attrs_define
class SearchResult:
    """ 
        Attributes:
            distance (float): L2 distance between the unit descriptors, in [0, 2].
            model (ModelSummary):
            score (float): 1 - distance^2 / 4, in [0, 1]; 1 for identical descriptors (the plain similarity, also where the
                hub discount and its re-rank order the results).
            calibrated_score (float | None | Unset): The share of pairs of different kinds of part (measured on the tuning
                sources) that score lower than this one: 0.99 means 1 % of different-kind pairs score as high. A threshold on it
                is a false-match rate (README, What a score means). Null for a descriptor layout without a calibration.
            explanation (Explanation | None | Unset): With `explain=true`, for the first few results (see the endpoint);
                null otherwise, and for a part placed past its time budget.
            likeness (None | SearchResultLikenessType0 | Unset): The calibrated score in words: "copy" from 0.995 (at most
                0.5 % of different-kind pairs score as high; about 95 % of re-sampled copies and 40 % of same-kind pairs do),
                "same kind" from 0.95 (5 %; about 70 % of same-kind pairs), "different kind" below. Words for reading, not
                proof: a copy at another size and a same-kind part of the same proportions read alike (compare sizes, or
                /v1/models/{id}/compare/{other_id}). Null without a calibration.
            where_used (list[WhereUsedEntry] | None | Unset): With `where_used=true` only: the assemblies that contain this
                model or a copy of it, as `GET /v1/models/{id}/where-used` answers.
     """

    distance: float
    model: ModelSummary
    score: float
    calibrated_score: float | None | Unset = UNSET
    explanation: Explanation | None | Unset = UNSET
    likeness: None | SearchResultLikenessType0 | Unset = UNSET
    where_used: list[WhereUsedEntry] | None | Unset = UNSET
    additional_properties: dict[str, Any] = _attrs_field(init=False, factory=dict)





    def to_dict(self) -> dict[str, Any]:
        from ..models.explanation import Explanation # noqa: PLC0415
        from ..models.model_summary import ModelSummary # noqa: PLC0415
        from ..models.where_used_entry import WhereUsedEntry # noqa: PLC0415
        distance = self.distance

        model = self.model.to_dict()

        score = self.score

        calibrated_score: float | None | Unset
        if isinstance(self.calibrated_score, Unset):
            calibrated_score = UNSET
        else:
            calibrated_score = self.calibrated_score

        explanation: dict[str, Any] | None | Unset
        if isinstance(self.explanation, Unset):
            explanation = UNSET
        elif isinstance(self.explanation, Explanation):
            explanation = self.explanation.to_dict()
        else:
            explanation = self.explanation

        likeness: None | str | Unset
        if isinstance(self.likeness, Unset):
            likeness = UNSET
        elif isinstance(self.likeness, SearchResultLikenessType0):
            likeness = self.likeness.value
        else:
            likeness = self.likeness

        where_used: list[dict[str, Any]] | None | Unset
        if isinstance(self.where_used, Unset):
            where_used = UNSET
        elif isinstance(self.where_used, list):
            where_used = []
            for where_used_type_0_item_data in self.where_used:
                where_used_type_0_item = where_used_type_0_item_data.to_dict()
                where_used.append(where_used_type_0_item)


        else:
            where_used = self.where_used


        field_dict: dict[str, Any] = {}
        field_dict.update(self.additional_properties)
        field_dict.update({
            "distance": distance,
            "model": model,
            "score": score,
        })
        if calibrated_score is not UNSET:
            field_dict["calibrated_score"] = calibrated_score
        if explanation is not UNSET:
            field_dict["explanation"] = explanation
        if likeness is not UNSET:
            field_dict["likeness"] = likeness
        if where_used is not UNSET:
            field_dict["where_used"] = where_used

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        from ..models.explanation import Explanation # noqa: PLC0415
        from ..models.model_summary import ModelSummary # noqa: PLC0415
        from ..models.where_used_entry import WhereUsedEntry # noqa: PLC0415
        d = dict(src_dict)
        distance = d.pop("distance")

        model = ModelSummary.from_dict(d.pop("model"))




        score = d.pop("score")

        def _parse_calibrated_score(data: object) -> float | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(float | None | Unset, data)

        calibrated_score = _parse_calibrated_score(d.pop("calibrated_score", UNSET))


        def _parse_explanation(data: object) -> Explanation | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            try:
                if not isinstance(data, dict):
                    raise TypeError()
                explanation_type_0 = Explanation.from_dict(data)



                return explanation_type_0
            except (TypeError, ValueError, AttributeError, KeyError):
                pass
            return cast(Explanation | None | Unset, data)

        explanation = _parse_explanation(d.pop("explanation", UNSET))


        def _parse_likeness(data: object) -> None | SearchResultLikenessType0 | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            try:
                if not isinstance(data, str):
                    raise TypeError()
                likeness_type_0 = SearchResultLikenessType0(data)



                return likeness_type_0
            except (TypeError, ValueError, AttributeError, KeyError):
                pass
            return cast(None | SearchResultLikenessType0 | Unset, data)

        likeness = _parse_likeness(d.pop("likeness", UNSET))


        def _parse_where_used(data: object) -> list[WhereUsedEntry] | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            try:
                if not isinstance(data, list):
                    raise TypeError()
                where_used_type_0 = []
                _where_used_type_0 = data
                for where_used_type_0_item_data in (_where_used_type_0):
                    where_used_type_0_item = WhereUsedEntry.from_dict(where_used_type_0_item_data)



                    where_used_type_0.append(where_used_type_0_item)

                return where_used_type_0
            except (TypeError, ValueError, AttributeError, KeyError):
                pass
            return cast(list[WhereUsedEntry] | None | Unset, data)

        where_used = _parse_where_used(d.pop("where_used", UNSET))


        search_result = cls(
            distance=distance,
            model=model,
            score=score,
            calibrated_score=calibrated_score,
            explanation=explanation,
            likeness=likeness,
            where_used=where_used,
        )


        search_result.additional_properties = d
        return search_result

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
