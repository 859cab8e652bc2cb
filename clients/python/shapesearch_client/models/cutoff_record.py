from __future__ import annotations

from collections.abc import Mapping
from typing import Any, TypeVar, BinaryIO, TextIO, TYPE_CHECKING, Generator

from attrs import define as _attrs_define
from attrs import field as _attrs_field

from ..types import UNSET, Unset

from ..types import UNSET, Unset
from typing import cast






T = TypeVar("T", bound="CutoffRecord")



@_attrs_define
class CutoffRecord:
    """ What the cutoff decided for one model: the one record of it that the database
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

        Attributes:
            mode (str):
            n (int):
            solver_calls (int):
            features (list[float] | None | Unset):
            margin (int | None | Unset):
            n_max (int | None | Unset):
            n_min (int | None | Unset):
            predicted (list[int] | Unset):
            prediction (int | None | Unset):
            prediction_held (bool | None | Unset):
            seed (int | None | Unset):
            t (float | None | Unset):
            xi (float | None | Unset):
     """

    mode: str
    n: int
    solver_calls: int
    features: list[float] | None | Unset = UNSET
    margin: int | None | Unset = UNSET
    n_max: int | None | Unset = UNSET
    n_min: int | None | Unset = UNSET
    predicted: list[int] | Unset = UNSET
    prediction: int | None | Unset = UNSET
    prediction_held: bool | None | Unset = UNSET
    seed: int | None | Unset = UNSET
    t: float | None | Unset = UNSET
    xi: float | None | Unset = UNSET
    additional_properties: dict[str, Any] = _attrs_field(init=False, factory=dict)





    def to_dict(self) -> dict[str, Any]:
        mode = self.mode

        n = self.n

        solver_calls = self.solver_calls

        features: list[float] | None | Unset
        if isinstance(self.features, Unset):
            features = UNSET
        elif isinstance(self.features, list):
            features = self.features


        else:
            features = self.features

        margin: int | None | Unset
        if isinstance(self.margin, Unset):
            margin = UNSET
        else:
            margin = self.margin

        n_max: int | None | Unset
        if isinstance(self.n_max, Unset):
            n_max = UNSET
        else:
            n_max = self.n_max

        n_min: int | None | Unset
        if isinstance(self.n_min, Unset):
            n_min = UNSET
        else:
            n_min = self.n_min

        predicted: list[int] | Unset = UNSET
        if not isinstance(self.predicted, Unset):
            predicted = self.predicted



        prediction: int | None | Unset
        if isinstance(self.prediction, Unset):
            prediction = UNSET
        else:
            prediction = self.prediction

        prediction_held: bool | None | Unset
        if isinstance(self.prediction_held, Unset):
            prediction_held = UNSET
        else:
            prediction_held = self.prediction_held

        seed: int | None | Unset
        if isinstance(self.seed, Unset):
            seed = UNSET
        else:
            seed = self.seed

        t: float | None | Unset
        if isinstance(self.t, Unset):
            t = UNSET
        else:
            t = self.t

        xi: float | None | Unset
        if isinstance(self.xi, Unset):
            xi = UNSET
        else:
            xi = self.xi


        field_dict: dict[str, Any] = {}
        field_dict.update(self.additional_properties)
        field_dict.update({
            "mode": mode,
            "n": n,
            "solver_calls": solver_calls,
        })
        if features is not UNSET:
            field_dict["features"] = features
        if margin is not UNSET:
            field_dict["margin"] = margin
        if n_max is not UNSET:
            field_dict["n_max"] = n_max
        if n_min is not UNSET:
            field_dict["n_min"] = n_min
        if predicted is not UNSET:
            field_dict["predicted"] = predicted
        if prediction is not UNSET:
            field_dict["prediction"] = prediction
        if prediction_held is not UNSET:
            field_dict["prediction_held"] = prediction_held
        if seed is not UNSET:
            field_dict["seed"] = seed
        if t is not UNSET:
            field_dict["t"] = t
        if xi is not UNSET:
            field_dict["xi"] = xi

        return field_dict



    @classmethod
    def from_dict(cls: type[T], src_dict: Mapping[str, Any]) -> T:
        d = dict(src_dict)
        mode = d.pop("mode")

        n = d.pop("n")

        solver_calls = d.pop("solver_calls")

        def _parse_features(data: object) -> list[float] | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            try:
                if not isinstance(data, list):
                    raise TypeError()
                features_type_0 = cast(list[float], data)

                return features_type_0
            except (TypeError, ValueError, AttributeError, KeyError):
                pass
            return cast(list[float] | None | Unset, data)

        features = _parse_features(d.pop("features", UNSET))


        def _parse_margin(data: object) -> int | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(int | None | Unset, data)

        margin = _parse_margin(d.pop("margin", UNSET))


        def _parse_n_max(data: object) -> int | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(int | None | Unset, data)

        n_max = _parse_n_max(d.pop("n_max", UNSET))


        def _parse_n_min(data: object) -> int | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(int | None | Unset, data)

        n_min = _parse_n_min(d.pop("n_min", UNSET))


        predicted = cast(list[int], d.pop("predicted", UNSET))


        def _parse_prediction(data: object) -> int | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(int | None | Unset, data)

        prediction = _parse_prediction(d.pop("prediction", UNSET))


        def _parse_prediction_held(data: object) -> bool | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(bool | None | Unset, data)

        prediction_held = _parse_prediction_held(d.pop("prediction_held", UNSET))


        def _parse_seed(data: object) -> int | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(int | None | Unset, data)

        seed = _parse_seed(d.pop("seed", UNSET))


        def _parse_t(data: object) -> float | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(float | None | Unset, data)

        t = _parse_t(d.pop("t", UNSET))


        def _parse_xi(data: object) -> float | None | Unset:
            if data is None:
                return data
            if isinstance(data, Unset):
                return data
            return cast(float | None | Unset, data)

        xi = _parse_xi(d.pop("xi", UNSET))


        cutoff_record = cls(
            mode=mode,
            n=n,
            solver_calls=solver_calls,
            features=features,
            margin=margin,
            n_max=n_max,
            n_min=n_min,
            predicted=predicted,
            prediction=prediction,
            prediction_held=prediction_held,
            seed=seed,
            t=t,
            xi=xi,
        )


        cutoff_record.additional_properties = d
        return cutoff_record

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
