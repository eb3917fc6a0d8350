"""The hand-made particle displacement models (predictors/displacement/models.py) and their registry
(predictors/displacement/registry.py): the common-displacement contract, the displacements, names."""

from __future__ import annotations

import numpy as np
import pytest

from predictors.displacement import (
    DISPLACEMENT_MODELS,
    Brownian,
    CommonDisplacementModel,
    ConstantVelocityDisplacement,
    DisplacementModel,
    make_displacement_model,
    motion_models,
)


def test_constant_velocity_extrapolates_the_estimates():
    model = ConstantVelocityDisplacement(0.0)
    assert isinstance(model, DisplacementModel)
    history = np.array([[[0.0, 0.0], [1.0, 0.5]]])
    out = model.propose(np.zeros((1, 3, 2)), history, np.random.default_rng(0))
    np.testing.assert_allclose(out, np.broadcast_to([1.0, 0.5], (1, 3, 2)))


@pytest.mark.parametrize("model_cls", [Brownian, ConstantVelocityDisplacement])
def test_propose_is_the_common_displacement_plus_white_noise(model_cls):
    """The protocol: propose(x, h) = x + displacement(h)[:, None] + std·ε, with ε the same draws."""
    model = model_cls(np.array([0.5, 1.5]))
    history = np.array([[[0.0, 0.0], [0.3, 0.1]], [[np.nan, np.nan], [2.0, 2.0]]])
    particles = np.random.default_rng(0).normal(size=(2, 7, 2))
    out = model.propose(particles, history, np.random.default_rng(9))
    eps = np.random.default_rng(9).standard_normal((2, 7, 2))
    expected = particles + model.displacement(history)[:, None, :] + model.std[:, None, None] * eps
    np.testing.assert_allclose(out, expected, rtol=0, atol=1e-14)


def test_displacements_of_the_named_models():
    history = np.array([[[0.0, 0.0], [0.3, 0.1]], [[np.nan, np.nan], [2.0, 2.0]]])
    np.testing.assert_array_equal(Brownian().displacement(history), np.zeros((2, 2)))
    np.testing.assert_allclose(ConstantVelocityDisplacement().displacement(history), [[0.3, 0.1], [0.0, 0.0]])
    np.testing.assert_array_equal(
        ConstantVelocityDisplacement().displacement(history[:, :1]), np.zeros((2, 2))
    )


def test_the_registry_builds_every_named_model_and_passes_an_object_through():
    assert DISPLACEMENT_MODELS.names() == ["brownian", "cv", "lstm"]
    assert type(make_displacement_model("brownian", 0.5, 0.2)) is Brownian
    cv = make_displacement_model("cv", [0.5, 1.0], 2.0)
    assert type(cv) is ConstantVelocityDisplacement and isinstance(cv, CommonDisplacementModel)
    np.testing.assert_allclose(cv.std, [1.0, 2.0])
    assert make_displacement_model(cv, 9.0, 9.0) is cv
    assert isinstance(make_displacement_model("lstm", 0.5, 0.2), CommonDisplacementModel)


def test_registry_errors_name_the_value_and_the_valid_names():
    with pytest.raises(
        ValueError, match=r"unknown model 'kalman'; valid names are \['brownian', 'cv', 'lstm'\]"
    ):
        make_displacement_model("kalman", 1.0, 0.2)
    with pytest.raises(
        ValueError, match=r"model_weights='w' is for a learned model \['lstm'\], not model='cv'"
    ):
        make_displacement_model("cv", 1.0, 0.2, "w")
    with pytest.raises(ValueError, match=r"model_weights='w' is for a learned model by name"):
        make_displacement_model(Brownian(), 1.0, 0.2, "w")
    with pytest.raises(ValueError, match=r"have propose\(\), got 3"):
        make_displacement_model(3, 1.0, 0.2)  # type: ignore[arg-type]


def test_the_listing_gives_every_model_its_kind_and_the_agents_that_take_it():
    assert motion_models() == [(name, "displacement", ("pf",)) for name in ("brownian", "cv", "lstm")]
