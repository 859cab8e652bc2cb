from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset







T = TypeVar("T", bound="DeviationFigures")



@_attrs_define
class DeviationFigures:
    """ How far one part's points lie from the other part's surface (its sample points, each
    taken as the small disc of surface it stands for), in the reference's units.

        Attributes:
            max_ (float):
            mean (float):
            p95 (float): 95th percentile.
            rms (float):
            within (float): Share of the points within `tolerance`, in [0, 1].
     """

    max_: float
    mean: float
    p95: float
    rms: float
    within: float
    additional_properties: dict[str, Any] = _attrs_field(init=False, factory=dict)





    def to_dict(self) -> dict[str, Any]:
        max_ = self.max_

        mean = self.mean

        p95 = self.p95

        rms = self.rms

        within = self.within


        field_dict: dict[str, Any] = {}
        field_dict.update(self.additional_properties)
        field_dict.update({
            "max": max_,
            "mean": mean,
            "p95": p95,
            "rms": rms,
            "within": within,
        })

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        d = dict(src_dict)
        max_ = d.pop("max")

        mean = d.pop("mean")

        p95 = d.pop("p95")

        rms = d.pop("rms")

        within = d.pop("within")

        deviation_figures = cls(
            max_=max_,
            mean=mean,
            p95=p95,
            rms=rms,
            within=within,
        )


        deviation_figures.additional_properties = d
        return deviation_figures

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
