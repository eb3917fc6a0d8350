"""Training learned motion models: data from env truth or track files, one loop, one model file.

* `predictors.training.data` — tracks from an env's truth or a recorded track
file, the
  train / validation / test split by track, padding;
* `predictors.training.loop` — the seeded Adam loop every learned model trains
with;
* `predictors.training.recipes` — the training recipes by model kind
(``track train KIND``),
  each registered beside its family's predictor, trained with typed settings
  (`predictors.training.settings`);
  `predictors.training.command` — what every recipe's ``train(settings)``
  shares (data from the settings, the config, the sidecar's record);
* `predictors.belt_lstm.training` — losses and data of the belt LSTMs;
* `predictors.displacement_lstm.training` — the sine data, loss and
metrics of the displacement
  LSTM of the LSTM particle filter.

torch is imported by these modules; nothing else in [`predictors`][predictors] needs it to run a tracker.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from track_envs.infra.lazy import lazy_exports

if TYPE_CHECKING:
    from predictors.training.calibration import Recalibration, fit_recalibration
    from predictors.training.data import (
        TrackSet,
        TrackSplit,
        pad_tracks,
        split_tracks,
        tracks_from_env,
        tracks_from_file,
        tracks_from_positions,
    )
    from predictors.training.evaluate import OneStepResult, one_step_predictions
    from predictors.training.loop import History, TrainConfig, fit, seeded_init, trained_model_file
    from predictors.training.model_file import (
        ModelFile,
        ModelFileError,
        load_model,
        model_paths,
        require_shapes,
        save_model,
    )
    from predictors.training.recipes import (
        RECIPES,
        TrainingRecipe,
        available_recipes,
        register_recipe,
        training_recipe,
    )
    from predictors.training.settings import DataSettings, RecipeOption, TrainingSettings

__getattr__, __dir__, __all__ = lazy_exports(__name__, __file__)
