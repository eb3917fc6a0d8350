"""The ``lstm`` covariance line search: ``track train lstm``'s post-training step.

The plain LSTM predicts no uncertainty; Pollithy et al. (2020, Sec. IV-D) give it a scaled
identity covariance ``s·I`` and choose the scale by a line search for the best association
accuracy. Here the candidates are ``s = f · s₀`` for factors ``f`` on a log grid around ``s₀``, the
mean squared one-step error per axis on the validation tracks (what training stores as
``calibration.cov_scale``); each candidate tracks validation episodes (not trained on, but the
search picks its scale on them) with ``gnn`` ([`agents.episode.run_episode`][agents.run_episode]) and the
scale with the lowest mean e_mean (ties: the one nearest ``s₀``) is written back to the model file,
with the whole search in ``training.tuning`` ([`line_search`][track_apps.lstm_line_search.line_search]).

It runs a tracker, so it is no part of the belt LSTM recipe in [`predictors`][predictors]: ``track train
lstm`` ([`track_apps.cli.train`][track_apps.cli.train]) runs the recipe, then
[`lstm_tuner`][track_apps.lstm_line_search.lstm_tuner] on the file it wrote.
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from predictors.training.settings import TrainingSettings

#: Factors of ``s₀`` the line search tries.
FACTORS = tuple(float(f) for f in np.logspace(-1, 2, 7))


def tracker_e_mean(
    model: Any, env_id: str, env_kwargs: dict[str, Any], seeds: Sequence[int], steps: int | None
) -> float:
    """Mean over ``seeds`` of the episode e_mean of ``gnn`` with the belt model ``model``
    (episodes of ``steps`` frames at most)."""
    import gymnasium as gym

    import track_envs  # noqa: F401
    from agents.episode import run_episode
    from agents.gnn.agent import GnnAgent
    from predictors.belt_lstm.predictor import LSTMPredictor
    from track_envs.wrappers import TrackingMetrics

    values = []
    for seed in seeds:
        env = TrackingMetrics(gym.make(env_id, **env_kwargs))
        agent = GnnAgent(predictor=LSTMPredictor(model.kind, model))
        try:
            values.append(float(run_episode(env, agent, seed=seed, steps=steps).metrics["e_mean"]))
        finally:
            env.close()
    return float(np.mean(values))


def line_search(
    model_path: str | os.PathLike[str],
    *,
    env_id: str,
    env_kwargs: dict[str, Any],
    seeds: Sequence[int],
    steps: int | None,
    factors: Sequence[float] = FACTORS,
) -> dict[str, Any]:
    """Pick ``calibration.cov_scale`` of the ``lstm`` model file at ``model_path`` (rewritten);
    returns the search's record (candidates and their e_mean)."""
    from predictors.training.model_file import load_model, save_model

    model = load_model(model_path, kind="lstm")
    calibration = dict(model.meta.get("calibration", {}))
    s0 = float(calibration["cov_scale"])
    scores = []
    for f in factors:
        candidate = dataclasses.replace(
            model, meta={**model.meta, "calibration": {**calibration, "cov_scale": s0 * f, "scale": 1.0}}
        )
        scores.append(tracker_e_mean(candidate, env_id, env_kwargs, seeds, steps))
    order = np.lexsort((np.abs(np.log(np.asarray(factors))), np.asarray(scores)))
    best = int(order[0])
    calibration.update(cov_scale=s0 * factors[best], scale=1.0, cov_scale_mse=s0)
    save_model(model_path, dataclasses.replace(model, meta={**model.meta, "calibration": calibration}))
    return {
        "method": "line search of cov_scale on gnn e_mean",
        "env_id": env_id,
        "env_kwargs": env_kwargs,
        "seeds": list(seeds),
        "steps": steps,
        "factors": list(factors),
        "e_mean": scores,
        "best_cov_scale": s0 * factors[best],
    }


def lstm_tuner(model_path: Path, settings: TrainingSettings) -> dict[str, Any]:
    """``track train lstm``'s post-training step: the line search on validation episodes.

    Validation data (not trained on; the search picks the scale on them): env episodes with seeds
    after the training ones (``--data-seed + --episodes + 100 …``, 1,000 frames each) or, for
    ``--tracks``, the replayed file; the added noise is the largest of ``--added-noise-std`` (at
    least 0.1 mm: the line search needs association errors to separate the candidates).
    """
    from predictors.belt_lstm.training import check_noise_std

    data = settings.data
    noise = max(check_noise_std(data.added_noise_std)[1], 1e-4)
    if data.env:
        env_id, env_kwargs = data.env, {**data.env_kwargs, "noise_std": noise}
        first = data.data_seed + data.episodes + 100
        seeds, steps = [first, first + 1], 1000
    else:
        env_id, env_kwargs = "BeltReplay-v0", {"path": data.tracks, "dt": data.dt, "noise_std": noise}
        seeds, steps = [0], None
    print(f"lstm: line search of the covariance scale on {env_id} (noise {noise:g}) ...")
    return line_search(model_path, env_id=env_id, env_kwargs=env_kwargs, seeds=seeds, steps=steps)
