"""COCO skeleton, walking-gait kinematics and body silhouettes of 2-D articulated people.

Everything is batched over people (leading axis ``n``) and keypoints (17, COCO order, see
[`track_envs.values.keypoints.KEYPOINT_NAMES`][track_envs.values.keypoints.KEYPOINT_NAMES]). Image coordinates
are pixels, x to the right and y **down** (COCO convention).

The body model (fractions of the person's standing height ``h`` px):

* the pelvis centre sits above the lower ankle (the stance foot stays on the ground, so the body
  bobs with the gait); the neck (shoulder midpoint) is ``torso · h`` above it, the head centre
  ``neck_len · h`` above the neck;
* each limb (upper arm, forearm, thigh, shin) is a rigid segment of length ``limb_k · h`` whose
  image angle from the downward vertical is its sagittal swing angle times ``cos ψ``
  (``ψ``: walking direction in the ground plane, 0 = to the right, +π/2 = away from the camera),
  so the swing shows in full from the side and vanishes toward / away from the camera, while
  the 2-D limb length stays exactly ``limb_k · h``;
* the left side sits ``−sin ψ · half_width · h`` to the side of the midline (shoulders, hips,
  eyes, ears), so a person facing the camera shows its left on the image right.

Gait (per person: cadence from speed and stride length, amplitude growing with speed): with
phase ``φ``, thigh angles ``±A_leg sin φ`` (left, right), knee flexion ``A_knee·max(0, sin(φ + 1.2))``
(mirrored for the right leg), arm swing ``∓A_arm sin φ`` counter to the legs, elbow flexion.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from track_envs.infra.arguments import check_int, check_non_negative, check_number, check_positive
from track_envs.values.keypoints import SKELETON_EDGES as SKELETON_EDGES  # the COCO limbs, also from here

#: Keypoint index of the left/right partner of each keypoint (itself for the nose).
FLIP_INDEX: NDArray[np.int64] = np.array([0, 2, 1, 4, 3, 6, 5, 8, 7, 10, 9, 12, 11, 14, 13, 16, 15])

#: The 8 limbs whose 2-D length is fixed per person: (parent, child) keypoints.
LIMBS: NDArray[np.int64] = np.array([[5, 7], [7, 9], [6, 8], [8, 10], [11, 13], [13, 15], [12, 14], [14, 16]])

#: Mean proportions (fractions of standing height) and their per-person spread (relative std).
PROPORTIONS: dict[str, float] = {
    "upper_arm": 0.186,
    "forearm": 0.146,
    "thigh": 0.245,
    "shin": 0.246,
    "torso": 0.29,
    "neck_len": 0.105,
    "shoulder_half": 0.13,
    "hip_half": 0.09,
}
PROPORTION_SPREAD = 0.05
_IS_LEFT = np.array([0, 1, 0, 1, 0, 1, 0, 1, 0, 1, 0, 1, 0, 1, 0, 1, 0], dtype=bool)
_IS_RIGHT = np.array([0, 0, 1, 0, 1, 0, 1, 0, 1, 0, 1, 0, 1, 0, 1, 0, 1], dtype=bool)


def draw_proportions(rng: np.random.Generator, n: int) -> NDArray[np.float64]:
    """Per-person body proportions (n, 8) in the order of
    [`PROPORTIONS`][track_envs.envs.skeleton.PROPORTIONS]."""
    mean = np.array(list(PROPORTIONS.values()))
    return mean * (1.0 + PROPORTION_SPREAD * np.clip(rng.standard_normal((n, len(mean))), -2.5, 2.5))


def _limb(angle: NDArray, length: NDArray) -> NDArray:
    """Image vector (n, 2) of limbs at ``angle`` from the downward vertical (x right, y down)."""
    return np.stack([length * np.sin(angle), length * np.cos(angle)], axis=-1)


def pose_keypoints(
    foot: NDArray, height: NDArray, heading: NDArray, phase: NDArray, amplitude: NDArray, props: NDArray
) -> NDArray[np.float64]:
    """The 17 keypoints of ``n`` walkers.

    Args:
        foot: (n, 2) image point on the ground under the person (px).
        height: (n,) standing height ``h`` in px (the person's scale).
        heading: (n,) walking direction ``ψ`` in the ground plane (rad).
        phase: (n,) gait phase ``φ`` (rad).
        amplitude: (n,) gait amplitude in [0, 1] (0 = standing still).
        props: (n, 8) proportions from [`draw_proportions`][track_envs.envs.skeleton.draw_proportions].

    Returns:
        (n, 17, 2) keypoints in px, COCO order.
    """
    h = height
    side = np.cos(heading)  # signed sagittal projection: + walking right
    lat = -np.sin(heading)  # image offset direction of the person's left side
    ua, fa, th, sh, torso, neck, sho, hip = (props[:, i] * h for i in range(8))
    a_leg = 0.42 * amplitude
    a_knee = 0.75 * amplitude
    a_arm = 0.38 * amplitude
    s = np.sin(phase)
    thigh_l, thigh_r = a_leg * s, -a_leg * s
    shin_l = thigh_l - a_knee * np.maximum(0.0, np.sin(phase + 1.2)) - 0.05
    shin_r = thigh_r - a_knee * np.maximum(0.0, np.sin(phase + np.pi + 1.2)) - 0.05
    arm_l, arm_r = -a_arm * s, a_arm * s
    fore_l = arm_l + 0.25 + 0.25 * amplitude * np.maximum(0.0, -s)
    fore_r = arm_r + 0.25 + 0.25 * amplitude * np.maximum(0.0, s)
    knee_l = _limb(thigh_l * side, th)
    knee_r = _limb(thigh_r * side, th)
    ankle_l = knee_l + _limb(shin_l * side, sh)
    ankle_r = knee_r + _limb(shin_r * side, sh)
    drop = np.maximum(ankle_l[:, 1], ankle_r[:, 1])  # stance foot on the ground
    pelvis = foot - np.stack([np.zeros_like(h), drop], axis=-1)
    up = np.stack([0.02 * h * side, -torso], axis=-1)  # slight forward lean
    neck_pt = pelvis + up
    head = neck_pt + np.stack([0.03 * h * side, -neck], axis=-1)
    facing_cam = np.sin(heading) < 0

    def off(dx: NDArray) -> NDArray:
        return np.stack([dx, np.zeros_like(dx)], axis=-1)

    kp = np.empty((len(h), 17, 2))
    hip_l, hip_r = pelvis + off(lat * hip), pelvis - off(lat * hip)
    sho_l, sho_r = neck_pt + off(lat * sho), neck_pt - off(lat * sho)
    kp[:, 11], kp[:, 12] = hip_l, hip_r
    kp[:, 13], kp[:, 14] = hip_l + knee_l, hip_r + knee_r
    kp[:, 15], kp[:, 16] = hip_l + ankle_l, hip_r + ankle_r
    kp[:, 5], kp[:, 6] = sho_l, sho_r
    elb_l = sho_l + _limb(arm_l * side, ua)
    elb_r = sho_r + _limb(arm_r * side, ua)
    kp[:, 7], kp[:, 8] = elb_l, elb_r
    kp[:, 9], kp[:, 10] = elb_l + _limb(fore_l * side, fa), elb_r + _limb(fore_r * side, fa)
    face = np.where(facing_cam, 1.0, 0.4)  # the face shows in full toward the camera
    fwd = 0.045 * h * side
    kp[:, 0] = head + np.stack([fwd * 1.4, 0.01 * h], axis=-1)
    kp[:, 1] = head + np.stack([fwd + 0.032 * h * lat * face, -0.012 * h], axis=-1)
    kp[:, 2] = head + np.stack([fwd - 0.032 * h * lat * face, -0.012 * h], axis=-1)
    kp[:, 3] = head + np.stack([-0.01 * h * side + 0.07 * h * lat, np.zeros_like(h)], axis=-1)
    kp[:, 4] = head + np.stack([-0.01 * h * side - 0.07 * h * lat, np.zeros_like(h)], axis=-1)
    return kp


def silhouette_segments(kp: NDArray, height: NDArray, heading: NDArray) -> tuple[NDArray, NDArray, NDArray]:
    """Capsules approximating each body: segment ends (n, S, 2) twice and radii (n, S) px.

    The torso (neck to pelvis, wider seen from the front), the head, the upper arms, forearms,
    thighs and shins.
    """
    neck = 0.5 * (kp[:, 5] + kp[:, 6])
    pelvis = 0.5 * (kp[:, 11] + kp[:, 12])
    head = 0.5 * (kp[:, 3] + kp[:, 4])
    width = np.abs(np.sin(heading))
    a = np.stack([neck, head, *(kp[:, i] for i in LIMBS[:, 0])], axis=1)
    b = np.stack([pelvis, head, *(kp[:, i] for i in LIMBS[:, 1])], axis=1)
    frac = np.array([0.0, 0.075, 0.035, 0.03, 0.035, 0.03, 0.05, 0.04, 0.05, 0.04])
    radius = frac[None, :] * height[:, None]
    radius[:, 0] = (0.09 + 0.05 * width) * height
    return a, b, radius


def point_segment_distance(p: NDArray, a: NDArray, b: NDArray) -> NDArray:
    """Distances between points ``p`` (..., 2) and segments ``a``–``b`` (..., 2), broadcast."""
    ab = b - a
    ap = p - a
    t = np.clip(np.sum(ap * ab, -1) / np.maximum(np.sum(ab * ab, -1), 1e-12), 0.0, 1.0)
    gap = ap - t[..., None] * ab
    return np.sqrt(gap[..., 0] ** 2 + gap[..., 1] ** 2)


def self_occluded(kp: NDArray, height: NDArray, heading: NDArray) -> NDArray[np.bool_]:
    """(n, 17) keypoints of the far side hidden behind the near side's body in side views.

    The far side is the left one when walking right (``cos ψ > 0``). Seen from the side
    (``|cos ψ| > 0.5``), a far arm keypoint behind the torso capsule, a far leg keypoint within
    the near leg's capsules and the far ear are hidden; the nose and eyes are hidden when the
    person walks away from the camera (``sin ψ > 0.5``).
    """
    side = np.cos(heading)
    far_left = side > 0
    far = np.where(far_left[:, None], _IS_LEFT[None], _IS_RIGHT[None])  # (n, 17)
    sideways = np.abs(side) > 0.5
    a, b, r = silhouette_segments(kp, height, heading)
    torso_d = point_segment_distance(kp, a[:, :1], b[:, :1])  # (n, 17)
    near_leg = np.where(far_left[:, None], np.array([6, 7])[None], np.array([4, 5])[None]) + 2
    rows = np.arange(len(kp))[:, None]
    leg_d = np.min(
        point_segment_distance(kp[:, :, None], a[rows, near_leg][:, None], b[rows, near_leg][:, None]), axis=2
    )
    arm = np.zeros(17, dtype=bool)
    arm[5:11] = True
    leg = np.zeros(17, dtype=bool)
    leg[13:17] = True
    ear = np.zeros(17, dtype=bool)
    ear[3:5] = True
    hidden = (
        far
        & sideways[:, None]
        & (
            (arm[None] & (torso_d < r[:, :1] * 0.9))
            | (leg[None] & (leg_d < 0.045 * height[:, None]))
            | ear[None]
        )
    )
    face = np.zeros(17, dtype=bool)
    face[:3] = True
    hidden |= face[None] & (np.sin(heading) > 0.5)[:, None]
    return hidden


# -- the crowd: people walking on a ground plane seen by a (panning) camera ----------------------
@dataclass(frozen=True)
class WalkerParams:
    """Camera and walking behaviour of KeypointWalkers (metres, seconds, pixels).

    The camera looks horizontally from ``camera_height`` m: a person at depth ``Z`` m and lateral
    position ``X`` m stands at image ``x = width/2 + focal·X/Z − pan_x``, ``y_foot = horizon +
    focal·camera_height/Z − pan_y`` and is ``focal·height_m/Z`` px tall.
    """

    width: int = 1280
    height: int = 720
    fps: float = 30.0
    focal: float = 900.0
    horizon: float = 200.0
    camera_height: float = 1.6
    depth_range: tuple[float, float] = (4.0, 14.0)
    height_range: tuple[float, float] = (1.5, 1.95)
    speed_range: tuple[float, float] = (0.8, 1.7)
    stride_factor: float = 0.8  # gait cycle length (two steps) in body heights
    heading_std: float = 0.35  # rad, spread of the walking direction about the lateral one
    event_rate: float = 0.3  # per person and second: stop, turn or change speed
    stop_duration: tuple[float, float] = (1.0, 3.0)
    turn_std: float = 0.6
    vanish_duration: tuple[float, float] = (0.5, 2.0)
    pan_change_rate: float = 1.0  # per second: the pan velocity jumps to a new value
    pillar_depth: float = 3.0
    pillar_width: float = 0.45

    def __post_init__(self) -> None:
        check_int("width", self.width, 1)
        check_int("height", self.height, 1)
        for name in ("fps", "focal", "camera_height", "stride_factor", "pillar_depth"):
            check_positive(name, getattr(self, name))
        check_number("horizon", self.horizon)
        for name in ("heading_std", "event_rate", "turn_std", "pan_change_rate", "pillar_width"):
            check_non_negative(name, getattr(self, name))
        for name in ("depth_range", "height_range", "speed_range", "stop_duration", "vanish_duration"):
            value = getattr(self, name)
            if not (isinstance(value, tuple | list) and len(value) == 2):
                raise ValueError(f"{name} must be a (low, high) pair, got {value!r}")
            low, high = (check_positive(f"{name}[{k}]", v) for k, v in enumerate(value))
            if low > high:
                raise ValueError(f"{name} must have low <= high, got {value!r}")


@dataclass(frozen=True)
class CrowdFrame:
    """The people of one frame: ids (n,), keypoints (n, 17, 2) px, keypoint_visible (n, 17),
    scale (n,) standing height px, head_size (n,) px, depth (n,) m."""

    ids: NDArray[np.int64]
    keypoints: NDArray[np.float64]
    keypoint_visible: NDArray[np.bool_]
    scale: NDArray[np.float64]
    head_size: NDArray[np.float64]
    depth: NDArray[np.float64]


_STATE = ("x", "z", "heading", "speed", "target", "phase", "height", "stop", "hide")
_HEAD_SIZE = 0.6 * float(np.hypot(0.13, 0.10))  # PoseTrack: 0.6 × head-box diagonal, per unit height


class Crowd:
    """Walkers entering, walking, stopping, turning, vanishing and leaving; batched over people.

    Args:
        params: Camera and behaviour.
        rng: The generator of every draw (the env's ``np_random``).
        num_people: Most people at once; ``initial_people`` start in view.
        arrival_rate: New people per second (from the left or right border).
        num_occluders: Static pillars at ``pillar_depth`` m, in front of every walker.
        vanish_rate: Per person and second, start of a spell with no visible keypoint.
        camera_pan: Largest pan speed (px/s); 0 for a static camera.
        occlusion: Occlusion by other people and self-occlusion on or off.
    """

    def __init__(
        self,
        params: WalkerParams,
        rng: np.random.Generator,
        *,
        num_people: int,
        initial_people: int,
        arrival_rate: float,
        num_occluders: int,
        vanish_rate: float,
        camera_pan: float,
        occlusion: bool,
    ) -> None:
        self.p, self.rng = params, rng
        self.num_people, self.arrival_rate = num_people, arrival_rate
        self.vanish_rate, self.camera_pan, self.occlusion = vanish_rate, camera_pan, occlusion
        self.dt = 1.0 / params.fps
        self.pan = np.zeros(2)
        self.pan_velocity = np.zeros(2)
        self.next_id = 0
        self.s: dict[str, NDArray] = {k: np.zeros(0) for k in _STATE}
        self.ids = np.zeros(0, dtype=np.int64)
        self.props = np.zeros((0, len(PROPORTIONS)))
        self.pillars = (
            (rng.uniform(-0.4, 0.4, num_occluders) * params.width) * params.pillar_depth / params.focal
        )
        self._spawn(initial_people, inside=True)
        self._cache: CrowdFrame | None = None

    # -- births, deaths, motion -------------------------------------------------------------------
    def _spawn(self, k: int, inside: bool) -> None:
        p, rng = self.p, self.rng
        if k <= 0:
            return
        z = rng.uniform(*p.depth_range, k)
        h_m = rng.uniform(*p.height_range, k)
        left = rng.random(k) < 0.5
        if inside:
            x_img = rng.uniform(0.1, 0.9, k) * p.width
        else:
            reach = 0.35 * p.focal * h_m / z  # just outside the border
            x_img = np.where(left, -reach, p.width + reach)
        x = (x_img + self.pan[0] - 0.5 * p.width) * z / p.focal
        heading = np.where(left, 0.0, np.pi) + p.heading_std * np.clip(rng.standard_normal(k), -2.5, 2.5)
        speed = rng.uniform(*p.speed_range, k)
        new = {
            "x": x, "z": z, "heading": heading, "speed": speed, "target": speed,
            "phase": rng.uniform(0, 2 * np.pi, k), "height": h_m, "stop": np.zeros(k), "hide": np.zeros(k),
        }  # fmt: skip
        self.s = {key: np.concatenate([self.s[key], new[key]]) for key in _STATE}
        self.ids = np.concatenate([self.ids, np.arange(self.next_id, self.next_id + k, dtype=np.int64)])
        self.props = np.concatenate([self.props, draw_proportions(rng, k)])
        self.next_id += k

    def step(self) -> None:
        """Move the scene one frame on (people, camera, births and departures)."""
        p, rng, s, dt = self.p, self.rng, self.s, self.dt
        n = len(self.ids)
        event = rng.random(n) < p.event_rate * dt
        kind = rng.integers(0, 3, n)
        s["stop"] = np.where(
            event & (kind == 0), rng.uniform(*p.stop_duration, n), np.maximum(s["stop"] - dt, 0)
        )
        s["heading"] = s["heading"] + np.where(event & (kind == 1), p.turn_std * rng.standard_normal(n), 0.0)
        s["target"] = np.where(event & (kind == 2), rng.uniform(*p.speed_range, n), s["target"])
        goal = np.where(s["stop"] > 0, 0.0, s["target"])
        s["speed"] = s["speed"] + (goal - s["speed"]) * min(1.0, dt / 0.4)
        s["x"] = s["x"] + s["speed"] * np.cos(s["heading"]) * dt
        s["z"] = s["z"] + s["speed"] * np.sin(s["heading"]) * dt
        lo, hi = p.depth_range
        bounce = ((s["z"] < lo) & (np.sin(s["heading"]) < 0)) | ((s["z"] > hi) & (np.sin(s["heading"]) > 0))
        s["heading"] = np.where(bounce, -s["heading"], s["heading"])
        s["phase"] = s["phase"] + 2 * np.pi * s["speed"] / (p.stride_factor * s["height"]) * dt
        vanish = rng.random(n) < self.vanish_rate * dt
        s["hide"] = np.where(
            vanish & (s["hide"] <= 0), rng.uniform(*p.vanish_duration, n), np.maximum(s["hide"] - dt, 0)
        )
        if self.camera_pan > 0:
            jump = rng.random() < p.pan_change_rate * dt
            new_velocity = rng.uniform(-1, 1, 2) * self.camera_pan * np.array([1.0, 0.15])
            self.pan_velocity = np.where(jump, new_velocity, self.pan_velocity)
            self.pan = self.pan + self.pan_velocity * dt
        # departures: out of view and walking outward, or far out of view
        x_img = self._foot()[:, 0]
        margin = 0.4 * self._scale()
        outward = ((x_img < -margin) & (np.cos(s["heading"]) < 0)) | (
            (x_img > p.width + margin) & (np.cos(s["heading"]) > 0)
        )
        keep = ~(outward | (np.abs(x_img - 0.5 * p.width) > 1.5 * p.width))
        self.s = {key: v[keep] for key, v in s.items()}
        self.ids, self.props = self.ids[keep], self.props[keep]
        births = int(rng.poisson(self.arrival_rate * dt)) if self.arrival_rate > 0 else 0
        self._spawn(min(births, self.num_people - len(self.ids)), inside=False)
        self._cache = None

    # -- projection and visibility ------------------------------------------------------------------
    def _scale(self) -> NDArray[np.float64]:
        return self.p.focal * self.s["height"] / self.s["z"]

    def _foot(self) -> NDArray[np.float64]:
        p, z = self.p, self.s["z"]
        x = 0.5 * p.width + p.focal * self.s["x"] / z - self.pan[0]
        y = p.horizon + p.focal * p.camera_height / z - self.pan[1]
        return np.stack([x, y], axis=-1)

    def horizon_px(self) -> float:
        """Image row (y down) of the horizon."""
        return float(self.p.horizon - self.pan[1])

    def pillars_px(self) -> list[tuple[float, float]]:
        """Image column ranges (x0, x1) of the pillars."""
        p = self.p
        c = 0.5 * p.width + p.focal * self.pillars / p.pillar_depth - self.pan[0]
        half = 0.5 * p.focal * p.pillar_width / p.pillar_depth
        return [(float(a - half), float(a + half)) for a in c]

    def frame(self) -> CrowdFrame:
        """Keypoints and visibility of the current frame (cached until the next
        [`step`][track_envs.envs.skeleton.Crowd.step])."""
        if self._cache is None:
            self._cache = self._compute_frame()
        return self._cache

    def _compute_frame(self) -> CrowdFrame:
        p, s = self.p, self.s
        h = self._scale()
        amplitude = np.clip(s["speed"] / 1.3, 0.0, 1.0)
        kp = pose_keypoints(self._foot(), h, s["heading"], s["phase"], amplitude, self.props)
        inside = (kp[..., 0] >= 0) & (kp[..., 0] < p.width) & (kp[..., 1] >= 0) & (kp[..., 1] < p.height)
        visible = inside & (s["hide"] <= 0)[:, None]
        for x0, x1 in self.pillars_px():
            visible &= ~((kp[..., 0] >= x0) & (kp[..., 0] <= x1))
        if self.occlusion and len(h):
            visible &= ~self_occluded(kp, h, s["heading"])
            visible &= ~self._occluded_by_others(kp, h)
        return CrowdFrame(
            ids=self.ids.copy(), keypoints=kp, keypoint_visible=visible, scale=h,
            head_size=_HEAD_SIZE * h, depth=s["z"].copy(),
        )  # fmt: skip

    def _occluded_by_others(self, kp: NDArray, h: NDArray) -> NDArray[np.bool_]:
        """(n, 17): keypoints inside the silhouette of a person closer to the camera."""
        a, b, r = silhouette_segments(kp, h, self.s["heading"])
        z = self.s["z"]
        # candidate pairs [i, j]: j in front of i and j's silhouette box overlaps i's keypoint box
        lo_i, hi_i = kp.min(axis=1), kp.max(axis=1)
        grow = r.max(axis=1)[:, None]
        lo_j = np.minimum(a.min(axis=1), b.min(axis=1)) - grow
        hi_j = np.maximum(a.max(axis=1), b.max(axis=1)) + grow
        overlap = np.all((lo_i[:, None] <= hi_j[None]) & (lo_j[None] <= hi_i[:, None]), axis=2)
        i, j = np.nonzero(overlap & (z[None, :] < z[:, None]))
        hidden = np.zeros(kp.shape[:2], dtype=bool)
        if len(i) == 0:
            return hidden
        d = point_segment_distance(kp[i][:, :, None], a[j][:, None], b[j][:, None])  # (pairs, 17, S)
        inside = np.any(d < r[j][:, None], axis=2)
        np.logical_or.at(hidden, i, inside)
        return hidden
