"""KeypointWalkers-v0: people walking through a camera image, seen by a 17-keypoint pose detector."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import linear_sum_assignment

from track_envs.contracts.report import Report
from track_envs.envs.base import TrackingEnv, Truth
from track_envs.envs.sensors import CLUTTER_ID
from track_envs.envs.skeleton import (
    FLIP_INDEX,
    PROPORTIONS,
    Crowd,
    WalkerParams,
    pose_keypoints,
)
from track_envs.infra.arguments import check_int, check_non_negative, check_positive, check_probability
from track_envs.metrics.keypoints import COCO_SIGMAS, oks
from track_envs.values.keypoints import SKELETON_EDGES
from track_envs.values.types import SensorSpec

__all__ = ["KeypointWalkersEnv", "WalkerParams"]

_REFERENCE_HEIGHT = 200.0  # px, the person size SensorSpec.noise_std refers to


@dataclass(frozen=True)
class _Detector:
    keypoint_noise: float
    p_detect: float
    p_keypoint: float
    clutter_rate: float
    swap_prob: float
    min_keypoints: int
    area_factor: float


class KeypointWalkersEnv(TrackingEnv):
    """Several people walk through a video frame; a pose detector reports their 17 COCO keypoints.

    ## Description
    The multi-person pose tracking scenes of Okada et al. (2020) (SMC pose tracking with a
    probabilistic pose predictor, evaluated on PoseTrack 2018), with the detector CNN replaced
    by a detector model. A 1280 × 720 px camera at 30 fps looks at a ground plane; up to
    ``num_people`` people at once enter from the left and right borders, walk across and leave.
    They stop, turn, change speed, and walk toward or away from the camera (their scale is
    ``focal · height / depth``). Each is a 2-D articulated skeleton with the 17 COCO keypoints
    (`track_envs.envs.skeleton`): person-specific height and proportions, a
    walking gait with person-specific cadence and stride, arms counter to legs. ``camera_pan`` adds a global
    image shift whose velocity changes abruptly (fast camera motion is the main failure of
    single-hypothesis trackers in Okada et al. (2020)). Crowd dynamics:
    `Crowd`.

    Visibility of each keypoint: inside the frame; not inside the body silhouette (capsules
    around torso, head and limbs) of a person closer to the camera; not self-occluded (the far
    side in side views, the face seen from behind); not behind a pillar (``num_occluders`` static
    pillars in front of the walkers); and the person is not in a vanishing spell (at
    ``vanish_rate`` per person and second, 0.5–2 s with no visible keypoint). So whole people
    disappear for a while and reappear, as in PoseTrack videos.

    ## Observation
    ``Dict(detections=Box(max_detections, 17, 3) float32, mask=Box(max_detections,) int8)``: per
    detected pose and keypoint ``x, y`` (px, x right, y down, clipped to the image) and a score in
    (0, 1]; score 0 (and x = y = 0) means the keypoint was not detected. Rows are shuffled. The
    detector model: a person with at least ``min_keypoints`` visible keypoints is detected with
    probability ``p_detect``; each visible keypoint with ``p_keypoint``, at its true position plus
    Gaussian noise of std ``keypoint_noise · 2σ_k · s`` per axis (``σ_k`` the COCO sigma,
    ``s = sqrt(area_factor) · h`` the OKS scale of a person ``h`` px tall); scores fall with the
    noise drawn. With probability ``swap_prob`` a detected pose has left and right swapped.
    ``Poisson(clutter_rate)`` false-positive poses per frame: random skeletons with a random subset
    of keypoints, large noise and low scores.

    ## Action
    The report (`track_envs.contracts.report`): ``ids``, ``positions``
    (max_tracks, 17, 2) px, ``detection``, ``mask``.

    ## Reward
    ``−GOSPA`` with the OKS distance ``d = 1 − OKS`` (cut-off c = 1, p = 1, α = 2): reported poses
    and visible truth poses are matched one-to-one by Hungarian assignment on ``1 − OKS`` (OKS over
    the truth's visible keypoints, area ``area_factor · h²``); the reward is
    ``−(Σ_matched (1 − OKS) + ½ (#unmatched truths + #unmatched reports))``. 0 is perfect. Duplicate
    ids are distinct rows.

    ## Starting State
    ``initial_people`` people (default half of ``num_people``) placed in view.

    ## Episode End
    No termination; ``gym.make`` truncates at 300 frames (10 s).

    ## Info
    ``t``, ``frame``, ``truth`` (``ids``, ``positions`` and ``keypoints`` (max_targets, 17, 2) px,
    ``keypoint_visible`` (max_targets, 17) bool, ``visible`` (any keypoint visible), ``scale``
    (standing height h in px), ``head_size`` (PoseTrack head size: 0.6 × head-box diagonal, px),
    ``depth`` (m)), ``detection_ids`` (-1 for false-positive poses), ``dropped_*``.

    ## Arguments
    - ``num_people``: most people in the scene at once (default 10); ``initial_people``;
      ``arrival_rate``: new people per second (default 1.0).
    - ``keypoint_noise`` (alias ``noise_std``): localisation noise in units of ``2σ_k · s`` (default 0.3).
    - ``p_detect`` (0.95), ``p_keypoint`` (0.97), ``clutter_rate`` (0.1), ``swap_prob`` (0.02),
      ``min_keypoints`` (3).
    - ``occlusion``: occlusion by other people and self-occlusion (default True).
    - ``num_occluders`` (1), ``vanish_rate`` (0.03 /s), ``camera_pan``: largest pan speed in px/s
      (0 = static camera).
    - ``params``: a `WalkerParams` for the rest (image size, camera,
    walking behaviour).
    - ``area_factor``: OKS area as a fraction of ``h²`` (0.2).
    - ``max_detections``, ``max_tracks``, ``max_targets`` (default 2·num_people + 8 each).
    - ``render_mode``: ``"rgb_array"`` or ``"human"``.

    SensorSpec: ``dim = 2``, region the image, ``noise_std`` the noise (px) of a mean-sigma
    keypoint of a person 200 px tall, ``clutter_rate`` in poses per frame, units ``"px"``.

    ## Version History
    - v0: the first version; its streams are those it had when added
      (2026-11-22), pinned since 2026-12-02.
    """

    metadata = {"render_modes": ["rgb_array", "human"], "render_fps": 30}  # noqa: RUF012

    def __init__(
        self,
        *,
        num_people: int = 10,
        initial_people: int | None = None,
        arrival_rate: float = 1.0,
        keypoint_noise: float | None = None,
        noise_std: float | None = None,
        p_detect: float = 0.95,
        p_keypoint: float = 0.97,
        clutter_rate: float = 0.1,
        swap_prob: float = 0.02,
        min_keypoints: int = 3,
        occlusion: bool = True,
        num_occluders: int = 1,
        vanish_rate: float = 0.03,
        camera_pan: float = 0.0,
        params: WalkerParams | None = None,
        area_factor: float = 0.2,
        max_detections: int | None = None,
        max_tracks: int | None = None,
        max_targets: int | None = None,
        render_mode: str | None = None,
    ):
        if keypoint_noise is not None and noise_std is not None:
            raise ValueError("pass keypoint_noise or its alias noise_std, not both")
        name, given = (
            ("noise_std", noise_std) if noise_std is not None else ("keypoint_noise", keypoint_noise)
        )
        noise = 0.3 if given is None else check_non_negative(name, given)
        self.params = params if params is not None else WalkerParams()
        if not isinstance(self.params, WalkerParams):
            raise ValueError(f"params must be a WalkerParams, got {type(self.params).__name__}")
        num_people = check_int("num_people", num_people, 1)
        initial = (
            num_people // 2 if initial_people is None else check_int("initial_people", initial_people, 0)
        )
        if initial > num_people:
            raise ValueError(f"initial_people must be <= num_people={num_people}, got {initial}")
        self.crowd_config: dict[str, Any] = {
            "num_people": num_people,
            "initial_people": initial,
            "arrival_rate": check_non_negative("arrival_rate", arrival_rate),
            "num_occluders": check_int("num_occluders", num_occluders, 0),
            "vanish_rate": check_non_negative("vanish_rate", vanish_rate),
            "camera_pan": check_non_negative("camera_pan", camera_pan),
            "occlusion": bool(occlusion),
        }
        self.detector = _Detector(
            keypoint_noise=noise,
            p_detect=check_probability("p_detect", p_detect),
            p_keypoint=check_probability("p_keypoint", p_keypoint),
            clutter_rate=check_non_negative("clutter_rate", clutter_rate),
            swap_prob=check_probability("swap_prob", swap_prob),
            min_keypoints=check_int("min_keypoints", min_keypoints, 1),
            area_factor=check_positive("area_factor", area_factor),
        )
        self.area_factor = self.detector.area_factor
        default_rows = 2 * num_people + 8
        rows = {
            name: default_rows if value is None else check_int(name, value, 1)
            for name, value in (
                ("max_detections", max_detections),
                ("max_tracks", max_tracks),
                ("max_targets", max_targets),
            )
        }
        p = self.params
        spec = SensorSpec(
            dt=1.0 / p.fps,
            dim=2,
            noise_std=float(noise * np.mean(2 * COCO_SIGMAS) * np.sqrt(area_factor) * _REFERENCE_HEIGHT),
            p_detect=self.detector.p_detect,
            clutter_rate=self.detector.clutter_rate,
            region_low=(0.0, 0.0),
            region_high=(float(p.width), float(p.height)),
            max_detections=rows["max_detections"],
            max_tracks=rows["max_tracks"],
            units="px",
        )
        self.metadata = {**self.metadata, "render_fps": p.fps}
        self._setup_spaces(
            spec,
            max_targets=rows["max_targets"],
            obs_low=np.zeros(3),
            obs_high=np.array([p.width, p.height, 1.0]),
            position_shape=(17, 2),
            detection_shape=(17, 3),
            truth_extra_shapes={
                "keypoints": (17, 2),
                "keypoint_visible": (17,),
                "scale": (),
                "head_size": (),
                "depth": (),
            },
            render_mode=render_mode,
        )
        self.crowd: Crowd | None = None

    # -- simulation ---------------------------------------------------------------------------
    def _reset_scene(self) -> None:
        self.crowd = Crowd(self.params, self.np_random, **self.crowd_config)

    def _advance(self) -> bool:
        assert self.crowd is not None
        self.crowd.step()
        return False

    def _truth(self) -> Truth:
        assert self.crowd is not None
        f = self.crowd.frame()
        return Truth(
            ids=f.ids,
            positions=f.keypoints,
            visible=np.asarray(f.keypoint_visible.any(axis=1), dtype=bool),
            extra={
                "keypoints": f.keypoints,
                "keypoint_visible": f.keypoint_visible,
                "scale": f.scale,
                "head_size": f.head_size,
                "depth": f.depth,
            },
        )

    def _sense(self, truth: Truth) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
        """The detector model (see the class docstring), batched over people and keypoints."""
        rng, det, p = self.np_random, self.detector, self.params
        vis = truth.extra["keypoint_visible"]
        scale = truth.extra["scale"]
        n = len(truth.ids)
        found = (vis.sum(axis=1) >= det.min_keypoints) & (rng.random(n) < det.p_detect)
        kp_found = vis & (rng.random((n, 17)) < det.p_keypoint)
        eps = rng.standard_normal((n, 17, 2))
        std = det.keypoint_noise * 2 * COCO_SIGMAS[None, :] * np.sqrt(det.area_factor) * scale[:, None]
        xy = truth.positions + eps * std[..., None]
        score = np.clip(
            0.5 + 0.45 * np.exp(-0.5 * np.sum(eps**2, -1)) + 0.05 * rng.standard_normal((n, 17)), 0.05, 1
        )
        swap = rng.random(n) < det.swap_prob
        z = np.concatenate([xy, np.where(kp_found, score, 0.0)[..., None]], axis=-1)
        z[swap] = z[swap][:, FLIP_INDEX]
        z = z[found]
        source = truth.ids[found]
        k = int(rng.poisson(det.clutter_rate)) if det.clutter_rate > 0 else 0
        if k:
            z = np.concatenate([z, self._clutter(k)])
            source = np.concatenate([source, np.full(k, CLUTTER_ID, dtype=np.int64)])
        z[..., 0] = np.clip(z[..., 0], 0.0, p.width)
        z[..., 1] = np.clip(z[..., 1], 0.0, p.height)
        z[..., :2] *= z[..., 2:] > 0  # undetected keypoints are all zero
        return z, source

    def _clutter(self, k: int) -> NDArray[np.float64]:
        """``k`` false-positive poses (k, 17, 3): random skeletons, partial, noisy, low scores."""
        rng, p = self.np_random, self.params
        h = rng.uniform(80.0, 350.0, k)
        foot = np.stack([rng.uniform(0, p.width, k), rng.uniform(0.4 * p.height, p.height, k)], -1)
        props = np.tile(np.array(list(PROPORTIONS.values())), (k, 1))
        kp = pose_keypoints(
            foot, h, rng.uniform(-np.pi, np.pi, k), rng.uniform(0, 2 * np.pi, k), rng.random(k), props
        )
        kp += rng.standard_normal((k, 17, 2)) * (0.05 * h)[:, None, None]
        score = np.where(rng.random((k, 17)) < 0.6, rng.uniform(0.05, 0.5, (k, 17)), 0.0)
        return np.concatenate([kp, score[..., None]], axis=-1)

    def _score(self, truth: Truth, report: Report) -> float:
        """Reward: −GOSPA on ``1 − OKS`` (c = 1, p = 1, α = 2), see the class docstring."""
        rows = truth.visible
        m, n = int(rows.sum()), len(report)
        if m == 0 or n == 0:
            return -0.5 * (m + n)
        sim = oks(
            truth.positions[rows],
            truth.extra["keypoint_visible"][rows],
            self.area_factor * truth.extra["scale"][rows] ** 2,
            report.positions,
        )
        r, c = linear_sum_assignment(1.0 - sim)
        cost = np.minimum(1.0 - sim[r, c], 1.0)
        return -float(cost.sum() + 0.5 * (m + n - 2 * len(r)))

    def default_metrics(self) -> list[Any]:
        """Per-keypoint MOTA (PCKh 0.5) and pose OKS
        (`track_envs.metrics.keypoints`), and HOTA with OKS as similarity
        ([`PoseHota`][track_envs.metrics.PoseHota])."""
        from track_envs.metrics.hota_stream import PoseHota
        from track_envs.metrics.keypoints import keypoint_metrics

        return [
            *keypoint_metrics(pckh=0.5, area_factor=self.area_factor),
            PoseHota(area_factor=self.area_factor),
        ]

    # -- rendering ----------------------------------------------------------------------------
    def _canvas(self) -> Any:
        from track_envs.envs.rendering import Canvas

        p = self.params
        return Canvas(p.width, p.height, (0.0, 0.0), (float(p.width), float(p.height)), (205, 215, 225))

    def _snapshot(self) -> Any:
        if self.crowd is None:
            return None
        return self.crowd.frame(), self.crowd.pillars_px(), self.crowd.horizon_px()

    def _flip(self, xy: NDArray) -> NDArray:
        """Image (x, y down) to canvas world (x, y up)."""
        return np.stack([xy[..., 0], self.params.height - xy[..., 1]], axis=-1)

    def _draw(self, canvas: Any, snapshot: Any) -> None:
        from track_envs.envs.rendering import identity_colors

        p = self.params
        if snapshot is None:
            return
        f, pillars, horizon = snapshot
        canvas.fill_rect((0.0, 0.0), (p.width, max(0.0, p.height - horizon)), (170, 170, 160))
        order = np.argsort(-f.depth, kind="stable")  # far to near: nearer people paint over
        kp = self._flip(f.keypoints[order])
        colors = identity_colors(f.ids[order])
        light = (0.55 * colors + 0.45 * 255).astype(np.uint8)
        torso = kp[:, [5, 6, 12, 11]]
        canvas.polygons(torso, light)
        canvas.discs(0.5 * (kp[:, 3] + kp[:, 4]), 0.065 * f.scale[order], light)
        a = kp[:, SKELETON_EDGES[:, 0]].reshape(-1, 2)
        b = kp[:, SKELETON_EDGES[:, 1]].reshape(-1, 2)
        canvas.segments(a, b, np.repeat(colors, len(SKELETON_EDGES), axis=0), thickness_px=3)
        vis = f.keypoint_visible[order]
        canvas.discs(kp[vis], 3, np.repeat(colors, 17, axis=0)[vis.reshape(-1)])
        for x0, x1 in pillars:
            canvas.fill_rect((x0, 0.0), (x1, p.height), (120, 100, 85))

    def _legend(self) -> list[Any]:
        from track_envs.envs.rendering import LegendEntry

        return [
            LegendEntry("person (truth)", "line"),
            LegendEntry("detected keypoint", "cross", (0, 0, 0)),
            LegendEntry("track", "outlined-line"),
            LegendEntry("pillar", "box", (120, 100, 85)),
        ]

    def _draw_overlay(self, canvas: Any, detections: NDArray, report: Report | None) -> None:
        """Detected keypoints as black crosses; reported poses as thin skeletons in id colours."""
        from track_envs.envs.rendering import identity_colors

        if len(detections):
            found = detections[..., 2] > 0
            canvas.crosses(self._flip(detections[..., :2][found]), 7, (0, 0, 0), thickness_px=1)
        if report is not None and len(report):
            kp = self._flip(report.positions)
            colors = np.repeat(identity_colors(report.ids), len(SKELETON_EDGES), axis=0)
            a = kp[:, SKELETON_EDGES[:, 0]].reshape(-1, 2)
            b = kp[:, SKELETON_EDGES[:, 1]].reshape(-1, 2)
            canvas.segments(a, b, (0, 0, 0), thickness_px=3)
            canvas.segments(a, b, colors, thickness_px=1)
