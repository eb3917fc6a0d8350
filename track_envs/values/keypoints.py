"""The COCO keypoint layout: the 17 keypoint names and the skeleton's limb edges.

Shared by the pose values ([`track_envs.values.poses`][track_envs.values.poses]), the pose files
([`track_envs.io.poses`][track_envs.io.poses]), the pose metrics
([`track_envs.metrics.keypoints`][track_envs.metrics.keypoints]) and the walkers' body model
([`track_envs.envs.skeleton`][track_envs.envs.skeleton]), which all import them from here.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["KEYPOINT_NAMES", "SKELETON_EDGES"]

#: COCO keypoint names, in COCO order.
KEYPOINT_NAMES: tuple[str, ...] = (
    "nose",
    "left_eye",
    "right_eye",
    "left_ear",
    "right_ear",
    "left_shoulder",
    "right_shoulder",
    "left_elbow",
    "right_elbow",
    "left_wrist",
    "right_wrist",
    "left_hip",
    "right_hip",
    "left_knee",
    "right_knee",
    "left_ankle",
    "right_ankle",
)

#: Limb edges of the COCO skeleton (0-based keypoint indices), as drawn by COCO tools.
SKELETON_EDGES: NDArray[np.int64] = np.array(
    [
        [15, 13], [13, 11], [16, 14], [14, 12], [11, 12], [5, 11], [6, 12], [5, 6], [5, 7],
        [6, 8], [7, 9], [8, 10], [1, 2], [0, 1], [0, 2], [1, 3], [2, 4], [3, 5], [4, 6],
    ],
    dtype=np.int64,
)  # fmt: skip
