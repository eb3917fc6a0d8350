"""Streaming, vectorised scorers of tracker reports against ground truth."""

from track_envs.metrics.aleatoric import AleatoricArea
from track_envs.metrics.base import Metric
from track_envs.metrics.belt import AssociationErrors
from track_envs.metrics.boxes import BoxClearMot, box_iou, iou_distances
from track_envs.metrics.clear_mot import ClearMot
from track_envs.metrics.gospa import GospaResult, gospa
from track_envs.metrics.gospa_stream import GospaMetric
from track_envs.metrics.hota import HotaAccumulator
from track_envs.metrics.hota_similarity import box_iou, point_similarity
from track_envs.metrics.hota_stream import Hota, PoseHota
from track_envs.metrics.keypoints import KeypointMota, PoseOks, oks, pairwise_oks
from track_envs.metrics.prediction import Nees, PredictionError, Reliability, mahalanobis_sq
from track_envs.metrics.single_target import SingleTargetError
from track_envs.metrics.sorting import SortingPrediction
from track_envs.metrics.track_error import TrackErrorDistribution

__all__ = [
    "AleatoricArea",
    "AssociationErrors",
    "BoxClearMot",
    "ClearMot",
    "GospaMetric",
    "GospaResult",
    "Hota",
    "HotaAccumulator",
    "KeypointMota",
    "Metric",
    "Nees",
    "PoseHota",
    "PoseOks",
    "PredictionError",
    "Reliability",
    "SingleTargetError",
    "SortingPrediction",
    "TrackErrorDistribution",
    "box_iou",
    "gospa",
    "iou_distances",
    "mahalanobis_sq",
    "oks",
    "pairwise_oks",
    "point_similarity",
]
