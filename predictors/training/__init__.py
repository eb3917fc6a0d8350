"""Training learned motion models: data from env truth or track files, one loop, one model file.

* :mod:`predictors.training.data` — tracks from an env's truth or a recorded track file, the
  train / validation / test split by track, padding;
* :mod:`predictors.training.loop` — the seeded Adam loop every learned model trains with;
* :mod:`predictors.training.recipes` — the training recipes by model kind (``track train KIND``),
  each registered beside its family's predictor; :mod:`predictors.training.command` — what every
  recipe's ``train(args)`` shares (data from the arguments, the config, the sidecar's record);
* :mod:`predictors.belt_lstm.training` — losses and data of the belt LSTMs;
* :mod:`predictors.displacement_lstm.training` — the sine data, loss and metrics of the displacement
  LSTM of the LSTM particle filter.

torch is imported by these modules; nothing else in :mod:`predictors` needs it to run a tracker.
"""
