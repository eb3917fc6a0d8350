"""Streaming, vectorised scorers of tracker reports against ground truth."""

from __future__ import annotations

from typing import TYPE_CHECKING

from track_envs.infra.lazy import lazy_exports
from track_envs.metrics.aleatoric import AleatoricArea
from track_envs.metrics.base import Metric, MetricTraits, metric_traits
from track_envs.metrics.belt import AssociationErrors
from track_envs.metrics.boxes import BoxClearMot, iou_distances
from track_envs.metrics.clear_mot import ClearMot
from track_envs.metrics.gospa import GospaResult, gospa
from track_envs.metrics.gospa_stream import GospaMetric
from track_envs.metrics.hota import HotaAccumulator
from track_envs.metrics.hota_similarity import box_iou, point_similarity
from track_envs.metrics.hota_stream import BoxHota, Hota, PoseHota
from track_envs.metrics.keypoints import KeypointMota, PoseOks, oks, pairwise_oks
from track_envs.metrics.prediction import Nees, PredictionError, Reliability, mahalanobis_sq
from track_envs.metrics.single_target import SingleTargetError
from track_envs.metrics.sorting import SortingPrediction
from track_envs.metrics.track_error import TrackErrorDistribution

if TYPE_CHECKING:
    from track_envs.metrics.crossing_check import CrossingScore, score_crossings
    from track_envs.metrics.defaults import point_metrics
    from track_envs.metrics.keypoints import keypoint_metrics
    from track_envs.metrics.pose_scoring import per_joint_mota, pose_hota, score_poses
    from track_envs.metrics.track_scoring import score_tracks

__getattr__, __dir__, __all__ = lazy_exports(__name__, __file__)
