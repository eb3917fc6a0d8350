"""The metric set of the point environments, which [`TrackingMetrics`][track_envs.wrappers.TrackingMetrics]
and [`score_tracks`][track_envs.metrics.score_tracks] score with."""

from __future__ import annotations

from track_envs.metrics.base import Metric
from track_envs.metrics.belt import AssociationErrors
from track_envs.metrics.clear_mot import ClearMot
from track_envs.metrics.gospa_stream import GospaMetric
from track_envs.metrics.hota_stream import Hota


def point_metrics(c: float) -> list[Metric]:
    """Metrics of multi-target point scenes: association errors e1 / e2 / e_mean (Pollithy et al. 2020), CLEAR
    MOT with match threshold ``c`` (MOTA, ID switches, IDF1), per-frame GOSPA (c, p = 2, α = 2) and HOTA
    (Luiten et al. 2021) with similarity ``max(0, 1 − d/c)``."""
    return [AssociationErrors(), ClearMot(threshold=c), GospaMetric(c=c), Hota(threshold=c)]
