r"""Pair scenes on a sorter belt with known truth, one per candidate cause of merged-blob mistakes.

A tracker with a merged-blob model ([`agents.jpda`][agents.jpda]) may explain one detection as the blob of two
tracks. Each scene here repeats one kind of encounter of two particles ``a`` and ``b`` (with a
third, a *neighbour* lane beside them) ``n_events`` times over one stream, in metres as the real
recordings (200 Hz, declared noise σ = 30 µm, no clutter, every particle detected), so that a
tracker's identities can be scored against truth per candidate:

* ``touching``: the case a merge model is built for (control) — equal spheres, ⌀ 4 mm, in lanes
  4.0–4.4 mm apart; ``b`` overtakes ``a`` at 0.02 m/s, so the two are seen as one blob at their
  midpoint for ≈10–25 frames;
* ``near-miss``: the same overtaking pair (0.05 m/s) in lanes 5–6 mm apart: the particles pass
  within 1–2 mm (centres closer than the 6 mm merge extent) without touching — two detections
  in every frame;
* ``unequal``: the touching pair of unequal spheres (⌀ 5 and 2.5 mm, area fractions 0.8 / 0.2,
  lanes 3.8–4.2 mm apart): the blob's centroid lies near the larger particle, not at the midpoint;
* ``rotation``: cylinders passing 3–7 mm apart (centres), touching below 4.5 mm; a
  rotating cylinder's detected centroid circles its centre (radius 0.3–0.8 mm, one turn in
  10–30 frames; the perspective and the shading of the end faces), a structured error far above
  the declared 30 µm;
* ``sparse``: the overtaking pairs of ``near-miss`` and ``touching`` (lanes 4–6 mm apart) on a
  belt at 2 m/s — 10 mm per frame at 200 Hz, more than the particles' spacing — closing at
  0.2 m/s, with a follower 8–14 mm behind ``a`` in its lane;
* ``accelerating``: particles fed onto the belt at 0.4–0.6 m/s that accelerate towards the belt's
  1 m/s (exponentially, time constant 20–40 ms), ``b`` later and faster than ``a``: the pair
  meets 6–9 frames after entering, while both tracks' accelerations are still changing; lanes
  4–6 mm apart, ⌀ 4 mm.

A particle's detection is its centroid (plus the rotation's offset); two particles whose outlines
come closer than [`CONTACT`][track_envs.streams.merge_scenes.CONTACT] (the segmentation joins them) give one
detection at the area-weighted centroid

.. math::

    z = w\, x_a + (1 - w)\, x_b + ε, \qquad w = \frac{r_a^2}{r_a^2 + r_b^2}, \quad ε \sim N(0, σ^2 I),

(as [`track_envs.envs.blobs`][track_envs.envs.blobs]; a pair only, the neighbour is never within reach).
Instance ``i`` enters the window (x = 0) at frame ``i · period`` in lateral slot ``i mod 8`` (slots 20 mm
apart), ``a`` and ``b`` side by side ``meet_frame`` frames later.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from track_envs.infra.arguments import check_int
from track_envs.streams.merge_events import (  # the same belt window, rate and noise
    DT,
    MAX_DETECTIONS,
    NOISE_STD,
    WINDOW_LENGTH,
    belt_spec,
)
from track_envs.values.types import SensorSpec

SLOTS, SLOT_PITCH = 8, 0.02
CONTACT = 5e-4  # m: outlines closer than this are one blob
PER_INSTANCE = 4  # a, b, neighbour, follower (the follower is only used by "sparse")
SCENES = ("touching", "near-miss", "unequal", "rotation", "sparse", "accelerating")


@dataclass(frozen=True)
class MergeScene:
    """One scene's stream: observations, truth and the encounters.

    Particle ``n`` has truth id ``n``; instance ``i`` holds ``4i`` (a), ``4i + 1`` (b), ``4i + 2``
    (neighbour) and ``4i + 3`` (follower, in the window only in ``sparse``).

    Attributes:
        name: One of `SCENES`.
        spec: The sensor (dt 0.005 s, D = 2, noise 3e-5 m, p_detect 1, no clutter).
        detections: (T, 64, 2) float32 rows, zero padded, shuffled per frame.
        mask: (T, 64) int8, 1 on real rows.
        detection_ids: (T, 64, 2) int64 truth ids behind each row, larger area first (−1 padded).
        positions: (T, N, 2) float64 true centres.
        visible: (T, N) bool, inside the window.
        meet_frames: (E,) the frame each pair is side by side.
        involved: (E, 2) the pair's truth ids.
    """

    name: str
    spec: SensorSpec
    detections: NDArray[np.float32]
    mask: NDArray[np.int8]
    detection_ids: NDArray[np.int64]
    positions: NDArray[np.float64]
    visible: NDArray[np.bool_]
    meet_frames: NDArray[np.int64]
    involved: NDArray[np.int64]

    def __len__(self) -> int:
        return len(self.detections)

    @property
    def truth_ids(self) -> NDArray[np.int64]:
        return np.arange(self.positions.shape[1], dtype=np.int64)

    def observation(self, t: int) -> dict[str, NDArray]:
        """Frame ``t``'s observation as an agent's ``act`` takes it."""
        return {"detections": self.detections[t], "mask": self.mask[t]}

    def truth(self, t: int) -> dict[str, NDArray]:
        """Frame ``t``'s truth as an env's ``info["truth"]``."""
        return {"ids": self.truth_ids, "positions": self.positions[t], "visible": self.visible[t]}

    def merged_rows(self) -> int:
        """Detection rows that are the blob of two particles, over the stream."""
        return int(np.count_nonzero(self.detection_ids[:, :, 1] >= 0))


@dataclass(frozen=True)
class _Layout:
    """One scene's draws: per instance ``(E,)`` arrays (lengths in m, speeds in m/s)."""

    speed: float  # belt speed
    closing: float  # b's speed over a's (m/s), before acceleration
    gap: tuple[float, float]  # range of the lanes' lateral distance
    radius: tuple[float, float]  # a's and b's radius (touching below their sum)
    meet: tuple[int, int]  # frames from entry to side by side
    wobble: tuple[float, float] = (0.0, 0.0)  # the rotation's centroid offset (radius range)
    accelerate: bool = False
    follower: bool = False


_LAYOUTS = {
    "touching": _Layout(1.0, 0.02, (4.0e-3, 4.4e-3), (2e-3, 2e-3), (20, 20)),
    "near-miss": _Layout(1.0, 0.05, (5e-3, 6e-3), (2e-3, 2e-3), (20, 20)),
    "unequal": _Layout(1.0, 0.02, (3.8e-3, 4.2e-3), (2.5e-3, 1.25e-3), (20, 20)),
    "rotation": _Layout(1.0, 0.05, (3e-3, 7e-3), (2e-3, 2e-3), (20, 20), wobble=(3e-4, 8e-4)),
    "sparse": _Layout(2.0, 0.2, (4e-3, 6e-3), (2e-3, 2e-3), (12, 12), follower=True),
    "accelerating": _Layout(1.0, 0.1, (4e-3, 6e-3), (2e-3, 2e-3), (6, 9), accelerate=True),
}


def merge_scene(name: str, rng: np.random.Generator, *, n_events: int = 24) -> MergeScene:
    """The stream of scene ``name`` (module docstring) with ``n_events`` encounters.

    Args:
        name: One of `SCENES`.
        rng: The stream's random generator.
        n_events: Encounters (>= 1).

    Raises:
        ValueError: for an unknown ``name`` (listing the valid ones), a bad ``n_events`` or ``rng``.
    """
    if name not in _LAYOUTS:
        raise ValueError(f"scene must be one of {list(SCENES)}, got {name!r}")
    if not isinstance(rng, np.random.Generator):
        raise ValueError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
    E = check_int("n_events", n_events, 1)
    lay = _LAYOUTS[name]
    slow = 0.4 if lay.accelerate else lay.speed
    crossing = int(np.ceil(WINDOW_LENGTH / slow / DT)) + 2
    period = int(np.ceil(1.1 * crossing / SLOTS))
    T = (E - 1) * period + crossing + 2
    N = PER_INSTANCE * E
    t = np.arange(T, dtype=np.float64) * DT
    pos = np.zeros((T, N, 2))
    offset = np.zeros((T, N, 2))  # the detected centroid's offset from the centre
    radius = np.zeros(N)
    meet = np.zeros(E, np.int64)
    for i in range(E):
        entry = i * period
        y0 = SLOT_PITCH * (i % SLOTS + 0.5) + rng.uniform(-2e-3, 2e-3)
        gap = rng.uniform(*lay.gap)
        side = rng.choice((-1.0, 1.0))
        meet_k = int(rng.integers(lay.meet[0], lay.meet[1] + 1))
        meet[i] = entry + meet_k
        tm = meet_k * DT  # time of the encounter after entry
        s: NDArray[np.float64] = t - entry * DT  # time since entry
        speeds = _speeds(rng, lay)
        xs = [_path(s, v0, v1, tau) for v0, v1, tau in speeds]
        # a enters at x = 0 at entry + jitter; b is placed to be side by side with a at tm
        xa = xs[0] - np.interp(0.0, s, xs[0]) + rng.uniform(0.0, 2e-3)
        xb = xs[1] - np.interp(tm, s, xs[1]) + np.interp(tm, s, xa)
        xn = xs[2] - np.interp(tm, s, xs[2]) + np.interp(tm, s, xa) + rng.uniform(-3e-3, 3e-3)
        xf = xa - rng.uniform(8e-3, 14e-3) if lay.follower else np.full(T, -1.0)
        ya = y0 - 0.5 * side * gap
        yb = y0 + 0.5 * side * gap
        yn = yb + side * rng.uniform(6.5e-3, 8e-3)
        for k, (x, y) in enumerate(((xa, ya), (xb, yb), (xn, yn), (xf, ya))):
            pos[:, PER_INSTANCE * i + k, 0] = x
            pos[:, PER_INSTANCE * i + k, 1] = y
        radius[PER_INSTANCE * i : PER_INSTANCE * i + 4] = (lay.radius[0], lay.radius[1], 2e-3, 2e-3)
        if lay.wobble[1] > 0:
            for k in range(3):
                r = rng.uniform(*lay.wobble)
                turn = rng.uniform(10, 30) * DT
                phase = rng.uniform(0, 2 * np.pi) + 2 * np.pi * s / turn
                offset[:, PER_INSTANCE * i + k, 0] = r * np.cos(phase)
                offset[:, PER_INSTANCE * i + k, 1] = r * np.sin(phase)
    visible = (pos[..., 0] >= 0.0) & (pos[..., 0] <= WINDOW_LENGTH)
    det, mask, ids = _detect(rng, pos, offset, radius, visible)
    involved = np.stack([PER_INSTANCE * np.arange(E), PER_INSTANCE * np.arange(E) + 1], axis=1)
    return MergeScene(name, belt_spec(), det, mask, ids, pos, visible, meet, involved.astype(np.int64))


def _speeds(rng: np.random.Generator, lay: _Layout) -> list[tuple[float, float, float]]:
    """``(start, end, time constant)`` of the speed of a, b and the neighbour."""
    v = lay.speed * rng.uniform(0.98, 1.02)
    if not lay.accelerate:
        return [(v, v, 1.0), (v + lay.closing, v + lay.closing, 1.0), (v, v, 1.0)]
    out = []
    for k in range(3):
        v0 = rng.uniform(0.4, 0.6)
        tau = rng.uniform(0.02, 0.04)
        end = v + (lay.closing if k == 1 else 0.0)
        out.append((v0, end, tau))
    return out


def _path(s: NDArray[np.float64], v0: float, v1: float, tau: float) -> NDArray[np.float64]:
    """Distance travelled after time ``s`` (any sign) at speed ``v1 − (v1 − v0) e^{−s/τ}`` (constant
    ``v0`` before ``s = 0``)."""
    after = np.maximum(s, 0.0)
    x = v1 * after - (v1 - v0) * tau * (1.0 - np.exp(-after / tau))
    return np.where(s > 0, x, v0 * s)


def _detect(
    rng: np.random.Generator,
    pos: NDArray[np.float64],
    offset: NDArray[np.float64],
    radius: NDArray[np.float64],
    visible: NDArray[np.bool_],
) -> tuple[NDArray[np.float32], NDArray[np.int8], NDArray[np.int64]]:
    """Detection rows, mask and merged ids per frame: touching pairs (a, b of one instance) as one
    area-weighted blob, every other visible particle alone; noise σ, rows shuffled."""
    T, N, _ = pos.shape
    det = np.zeros((T, MAX_DETECTIONS, 2), np.float32)
    mask = np.zeros((T, MAX_DETECTIONS), np.int8)
    ids = np.full((T, MAX_DETECTIONS, 2), -1, np.int64)
    a = np.arange(0, N, PER_INSTANCE)
    b = a + 1
    seen = pos + offset
    area = radius**2
    for t in range(T):
        touch = (
            visible[t, a]
            & visible[t, b]
            & (np.linalg.norm(pos[t, a] - pos[t, b], axis=1) < radius[a] + radius[b] + CONTACT)
        )
        alone = visible[t].copy()
        alone[a[touch]] = alone[b[touch]] = False
        rows_z = [seen[t, alone]]
        rows_id = [np.stack([np.flatnonzero(alone), np.full(int(alone.sum()), -1)], axis=1)]
        if touch.any():
            ta, tb = a[touch], b[touch]
            w = area[ta] / (area[ta] + area[tb])
            rows_z.append(w[:, None] * seen[t, ta] + (1 - w[:, None]) * seen[t, tb])
            first = np.where(w >= 0.5, ta, tb)
            rows_id.append(np.stack([first, np.where(w >= 0.5, tb, ta)], axis=1))
        z = np.concatenate(rows_z)
        zid = np.concatenate(rows_id)
        if len(z) > MAX_DETECTIONS:
            raise ValueError(f"frame {t} has {len(z)} detections, more than {MAX_DETECTIONS}")
        order = rng.permutation(len(z))
        k = len(z)
        det[t, :k] = z[order] + rng.normal(0.0, NOISE_STD, size=(k, 2))
        ids[t, :k] = zid[order]
        mask[t, :k] = 1
    return det, mask, ids
