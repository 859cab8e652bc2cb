from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from typing import cast
from uuid import UUID

if TYPE_CHECKING:
  from ..models.cutoff_record import CutoffRecord





T = TypeVar("T", bound="CutoffPoint")



@_attrs_define
class CutoffPoint:
    """ One ready model on the plot.

        Attributes:
            cutoff (CutoffRecord): What the cutoff decided for one model: the one record of it that the database
                stores (``to_json``), the API and the command line show, and the evaluation keeps.

                Attributes
                ----------
                mode : str
                    ``"adaptive"`` or ``"fixed"``.
                n : int
                    Eigenpairs used by the signatures.
                solver_calls : int
                    Calls to the eigen-solver that computed something (the seed counts as one).
                predicted : list of int
                    Unclamped ``n`` extrapolated in each round that had to ask for more (empty for a
                    fixed cutoff, or when the first call already decided).
                xi, t, seed, n_min, n_max, margin : float, float, int, int, int, int, or None
                    The adaptive cutoff's parameters (``AdaptiveCutoff``); None for a fixed cutoff.
                prediction : int or None
                    ``n`` predicted before the solve (``core.cutoff_predictor``), None without one.
                prediction_held : bool or None
                    Whether the first call, to ``prediction + 2 margin``, decided ``n`` (None without one).
                features : list of float or None
                    The pre-solve features the predictor learns ``n`` from (None when not recorded).
            external_id (None | str):
            id (UUID):
            n_points (int): Points the description used.
            name (None | str):
     """

    cutoff: CutoffRecord
    external_id: None | str
    id: UUID
    n_points: int
    name: None | str
    additional_properties: dict[str, Any] = _attrs_field(init=False, factory=dict)





    def to_dict(self) -> dict[str, Any]:
        from ..models.cutoff_record import CutoffRecord # noqa: PLC0415
        cutoff = self.cutoff.to_dict()

        external_id: None | str
        external_id = self.external_id

        id = str(self.id)

        n_points = self.n_points

        name: None | str
        name = self.name


        field_dict: dict[str, Any] = {}
        field_dict.update(self.additional_properties)
        field_dict.update({
            "cutoff": cutoff,
            "external_id": external_id,
            "id": id,
            "n_points": n_points,
            "name": name,
        })

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        from ..models.cutoff_record import CutoffRecord # noqa: PLC0415
        d = dict(src_dict)
        cutoff = CutoffRecord.from_dict(d.pop("cutoff"))




        def _parse_external_id(data: object) -> None | str:
            if data is None:
                return data
            return cast(None | str, data)

        external_id = _parse_external_id(d.pop("external_id"))


        id = UUID(d.pop("id"))




        n_points = d.pop("n_points")

        def _parse_name(data: object) -> None | str:
            if data is None:
                return data
            return cast(None | str, data)

        name = _parse_name(d.pop("name"))


        cutoff_point = cls(
            cutoff=cutoff,
            external_id=external_id,
            id=id,
            n_points=n_points,
            name=name,
        )


        cutoff_point.additional_properties = d
        return cutoff_point

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
