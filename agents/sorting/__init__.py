"""Sorting prediction: when and where each particle passes the nozzle bar, the tracker's side.

* [`predict_crossings`][agents.sorting.predict_crossings] (`.rollout`) — a predictor
rolled forward without measurements
  to the line ``x = L`` (what a point tracker reports in its sorting channel for the tracks it
  lets go);
* [`SortingCollector`][agents.sorting.SortingCollector] (`.collect`) — the sorting
channel of a stream of reports,
  gathered into [`track_envs.io.crossings.PredictedCrossings`][track_envs.io.PredictedCrossings];
* [`check_sorting`][agents.sorting.check_sorting] (`.check`) — the truth-free check of
those predictions on a
  recording that ends before the bar.

The report's sorting channel (a contract), its CSV file and its scores live with the other
contracts, files and scores: `track_envs.contracts.sorting_channel`,
`track_envs.io.crossings`,
`track_envs.metrics.crossing_check` and
`track_envs.metrics.sorting`.
"""

from agents.sorting.check import SortingCheck, check_sorting
from agents.sorting.collect import SortingCollector, sorting_spec
from agents.sorting.rollout import MAX_STEPS, predict_crossings
from track_envs.infra.lazy import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(__name__, __file__)
