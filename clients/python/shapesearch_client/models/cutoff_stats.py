from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from typing import cast

if TYPE_CHECKING:
  from ..models.cutoff_point import CutoffPoint
  from ..models.solver_calls_bin import SolverCallsBin





T = TypeVar("T", bound="CutoffStats")



@_attrs_define
class CutoffStats:
    """ The paper's Figure 7 for this database, and the solver-calls histogram.

        Attributes:
            fixed_n (int): The fixed cutoff the adaptive one is compared with.
            mean_n (float | None): Their mean adaptive cutoff n (null without any).
            models (list[CutoffPoint]): At most 2000 of them in point-count order: all of them, or every k-th by point count
                when there are more (a plot of every model of a large catalogue weighed tens of megabytes).
            ready_models (int): Ready models with a cutoff record.
            solver_calls (list[SolverCallsBin]): Ready models per solver-call count (every one of them).
     """

    fixed_n: int
    mean_n: float | None
    models: list[CutoffPoint]
    ready_models: int
    solver_calls: list[SolverCallsBin]
    additional_properties: dict[str, Any] = _attrs_field(init=False, factory=dict)





    def to_dict(self) -> dict[str, Any]:
        from ..models.cutoff_point import CutoffPoint # noqa: PLC0415
        from ..models.solver_calls_bin import SolverCallsBin # noqa: PLC0415
        fixed_n = self.fixed_n

        mean_n: float | None
        mean_n = self.mean_n

        models = []
        for models_item_data in self.models:
            models_item = models_item_data.to_dict()
            models.append(models_item)



        ready_models = self.ready_models

        solver_calls = []
        for solver_calls_item_data in self.solver_calls:
            solver_calls_item = solver_calls_item_data.to_dict()
            solver_calls.append(solver_calls_item)




        field_dict: dict[str, Any] = {}
        field_dict.update(self.additional_properties)
        field_dict.update({
            "fixed_n": fixed_n,
            "mean_n": mean_n,
            "models": models,
            "ready_models": ready_models,
            "solver_calls": solver_calls,
        })

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        from ..models.cutoff_point import CutoffPoint # noqa: PLC0415
        from ..models.solver_calls_bin import SolverCallsBin # noqa: PLC0415
        d = dict(src_dict)
        fixed_n = d.pop("fixed_n")

        def _parse_mean_n(data: object) -> float | None:
            if data is None:
                return data
            return cast(float | None, data)

        mean_n = _parse_mean_n(d.pop("mean_n"))


        models = []
        _models = d.pop("models")
        for models_item_data in (_models):
            models_item = CutoffPoint.from_dict(models_item_data)



            models.append(models_item)


        ready_models = d.pop("ready_models")

        solver_calls = []
        _solver_calls = d.pop("solver_calls")
        for solver_calls_item_data in (_solver_calls):
            solver_calls_item = SolverCallsBin.from_dict(solver_calls_item_data)



            solver_calls.append(solver_calls_item)


        cutoff_stats = cls(
            fixed_n=fixed_n,
            mean_n=mean_n,
            models=models,
            ready_models=ready_models,
            solver_calls=solver_calls,
        )


        cutoff_stats.additional_properties = d
        return cutoff_stats

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
