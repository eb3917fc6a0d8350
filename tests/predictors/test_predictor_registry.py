"""The predictor registry names the arguments each predictor takes."""

from __future__ import annotations

import pytest

from predictors import available_predictors, make_predictor
from track_envs.infra.registry import UnknownArgumentError

FIRST_ARGUMENT = {"lstm": "weights", "nll-lstm": "weights", "mc-lstm": "weights"}


@pytest.mark.parametrize("name", available_predictors())
def test_an_unknown_keyword_names_the_predictor_and_its_arguments(name: str) -> None:
    first = FIRST_ARGUMENT.get(name, "q")
    expected = rf"predictor '{name}' has no argument 'gate'; its arguments are \['{first}'"
    with pytest.raises(UnknownArgumentError, match=expected):
        make_predictor(name, gate=3)


def test_each_model_takes_only_the_arguments_it_uses() -> None:
    assert make_predictor("kf-ca", q=2.0, initial_acceleration_std=1.0).initial_acceleration_std == 1.0
    with pytest.raises(UnknownArgumentError, match="'kf-cv' has no argument 'initial_acceleration_std'"):
        make_predictor("kf-cv", initial_acceleration_std=1.0)
    with pytest.raises(
        UnknownArgumentError, match=r"'random-walk' has no argument 'initial_velocity'; .* \['q'\]"
    ):
        make_predictor("random-walk", initial_velocity=[1.0, 0.0])
