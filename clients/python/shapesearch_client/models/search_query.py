from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from typing import cast

if TYPE_CHECKING:
  from ..models.cutoff_record import CutoffRecord
  from ..models.size import Size





T = TypeVar("T", bound="SearchQuery")



@_attrs_define
class SearchQuery:
    """ The uploaded scan as described for the search (nothing is stored).

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
            descriptor_version (str):
            format_ (str):
            n_points (int):
            size (None | Size): As measured on the upload (a partial scan under-measures), in the units given with it.
     """

    cutoff: CutoffRecord
    descriptor_version: str
    format_: str
    n_points: int
    size: None | Size
    additional_properties: dict[str, Any] = _attrs_field(init=False, factory=dict)





    def to_dict(self) -> dict[str, Any]:
        from ..models.cutoff_record import CutoffRecord # noqa: PLC0415
        from ..models.size import Size # noqa: PLC0415
        cutoff = self.cutoff.to_dict()

        descriptor_version = self.descriptor_version

        format_ = self.format_

        n_points = self.n_points

        size: dict[str, Any] | None
        if isinstance(self.size, Size):
            size = self.size.to_dict()
        else:
            size = self.size


        field_dict: dict[str, Any] = {}
        field_dict.update(self.additional_properties)
        field_dict.update({
            "cutoff": cutoff,
            "descriptor_version": descriptor_version,
            "format": format_,
            "n_points": n_points,
            "size": size,
        })

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        from ..models.cutoff_record import CutoffRecord # noqa: PLC0415
        from ..models.size import Size # noqa: PLC0415
        d = dict(src_dict)
        cutoff = CutoffRecord.from_dict(d.pop("cutoff"))




        descriptor_version = d.pop("descriptor_version")

        format_ = d.pop("format")

        n_points = d.pop("n_points")

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


        search_query = cls(
            cutoff=cutoff,
            descriptor_version=descriptor_version,
            format_=format_,
            n_points=n_points,
            size=size,
        )


        search_query.additional_properties = d
        return search_query

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
