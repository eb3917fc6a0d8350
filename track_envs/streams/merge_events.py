"""Blob joins, blob separations and missed pairs on a sorter belt, each repeated over one stream.

On a sorter belt (≈1 m/s, 200 Hz, declared noise σ = 0.03 mm) three events make a tracker that
knows no merged blobs move its tracks: two particles in neighbouring lanes reported for one frame
as one blob (a *join*), a blob that enters as one detection and then falls apart into two
(a *separation*), and a side-by-side pair that gives no detection for one frame (a *missed pair*).
A blob's detection is the area-weighted centroid of its particles
([`track_envs.envs.blobs`][track_envs.envs.blobs]), for equal particles their midpoint

.. math::

    z = \\tfrac12 (x_a + x_b) + ε, \\qquad ε \\sim N(0, σ^2 I),

so a join moves the detection of either particle by half the lane gap (0.9 mm at 1.8 mm), and a
separation moves the pieces by ±1.5 mm from the blob's path: against a kf-ca prediction spread of
≈0.08 mm, 10–20 σ of innovation that a Kalman update puts into velocity and acceleration.

Each generator builds ``n_events`` independent instances of its event. Instance ``i`` enters the
window (x = 0) at frame ``i · period`` in lateral slot ``i mod 8`` (slots 20 mm apart across the
180 mm belt, so that the instances in view at once never meet) and consists of four particles:

* the involved pair ``a``, ``b``: side by side (x within ±0.2 mm), in two lanes ``gap`` apart
  around the slot's centre, at one speed ≈1 m/s (±2 %) and one small lateral drift
  (|v_y| <= 0.01 m/s, 0.05 mm per frame), so the lanes stay parallel;
* a *neighbour* lane 4–6 mm beside the pair (on a random side, x within ±3 mm, parallel to the
  pair's lanes, speed within ±1 % of theirs), the particle a track that jumps sideways lands on;
* a *follower* 10–20 mm behind the pair in one of its lanes.

The event happens ``lead_frames`` frames after the instance entered (a settled track), the
scoring window ([`track_envs.streams.merge_scoring`][track_envs.streams.merge_scoring]) is the ``window``
frames after it, and the window's end stays inside the 400 mm camera window. Every detected particle or blob
gives one detection row (p_detect 1, no clutter), rows shuffled per frame, noise added as declared.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from track_envs.infra.arguments import check_int, check_positive
from track_envs.values.types import SensorSpec

DT = 0.005  # s (200 Hz)
NOISE_STD = 3e-5  # m, declared and added
WINDOW_LENGTH, WINDOW_WIDTH = 0.40, 0.18  # m, the belt's camera window
SPEED = 1.0  # m/s along x
SLOTS = 8  # lateral slots of the instances in view at once
SLOT_PITCH = 0.02  # m
PER_INSTANCE = 4  # particles: a, b, neighbour, follower
MAX_DETECTIONS = MAX_TRACKS = 64
KINDS = ("join", "separation", "missed-pair")


@dataclass(frozen=True)
class MergeEventStream:
    """One scenario's stream: observations, truth and where its events are.

    Particle ``n`` has truth id ``n``; instance ``i`` holds particles ``4i`` (a), ``4i + 1`` (b),
    ``4i + 2`` (neighbour) and ``4i + 3`` (follower).

    Attributes:
        kind: ``"join"``, ``"separation"`` or ``"missed-pair"``.
        spec: The sensor (dt 0.005 s, D = 2, noise 3e-5 m, p_detect 1, no clutter).
        detections: (T, max_detections, D) float32 detection rows, zero padded.
        mask: (T, max_detections) int8, 1 on real rows.
        detection_ids: (T, max_detections, 2) int64 truth ids behind each row (−1 padded):
            ``[a, b]`` on a blob of the pair, ``[n, −1]`` on a particle's own detection.
        truth_ids: (N,) int64 truth ids (``arange(N)``).
        positions: (T, N, D) float64 true positions of every particle in every frame.
        visible: (T, N) bool, the particle is inside the camera window.
        event_frames: (E,) the event's frame: the join frame, the missed frame, or the first
            frame in which the separated pieces are detected apart.
        involved: (E, 2) truth ids of the pair of each event.
        entry_frames: (E,) the frame each instance entered the window.
        lane_gap: Lateral distance between the pair's lanes (m).
    """

    kind: str
    spec: SensorSpec
    detections: NDArray[np.float32]
    mask: NDArray[np.int8]
    detection_ids: NDArray[np.int64]
    truth_ids: NDArray[np.int64]
    positions: NDArray[np.float64]
    visible: NDArray[np.bool_]
    event_frames: NDArray[np.int64]
    involved: NDArray[np.int64]
    entry_frames: NDArray[np.int64]
    lane_gap: float

    def __len__(self) -> int:
        return len(self.detections)

    def observation(self, t: int) -> dict[str, NDArray]:
        """The observation of frame ``t`` as an agent's ``act`` takes it."""
        return {"detections": self.detections[t], "mask": self.mask[t]}

    def truth(self, t: int) -> dict[str, NDArray]:
        """Frame ``t``'s truth as an env's ``info["truth"]`` (ids, positions, visible)."""
        return {"ids": self.truth_ids, "positions": self.positions[t], "visible": self.visible[t]}


def belt_spec() -> SensorSpec:
    """The sensor of every merge-event stream: the belt's 400 × 180 mm window at 200 Hz."""
    return SensorSpec(
        dt=DT,
        dim=2,
        noise_std=NOISE_STD,
        p_detect=1.0,
        clutter_rate=0.0,
        region_low=(0.0, 0.0),
        region_high=(WINDOW_LENGTH, WINDOW_WIDTH),
        max_detections=MAX_DETECTIONS,
        max_tracks=MAX_TRACKS,
    )


def join_stream(
    rng: np.random.Generator, *, n_events: int = 20, lane_gap: float = 1.8e-3, **layout: int
) -> MergeEventStream:
    """Two lanes ``lane_gap`` apart whose particles are reported as one detection at their
    midpoint (plus noise) in exactly one frame, and apart again from the next.

    Args:
        rng: The stream's random generator.
        n_events: Instances of the event (>= 1).
        lane_gap: Lateral distance of the two lanes (m, in (0, 4 mm]).
        **layout: ``lead_frames``, ``window``, ``period``
            ([`_layout`][track_envs.streams.merge_events._layout]).
    """
    return _build("join", rng, n_events, _gap(lane_gap, "lane_gap"), layout)


def separation_stream(
    rng: np.random.Generator, *, n_events: int = 20, piece_offset: float = 1.5e-3, **layout: int
) -> MergeEventStream:
    """A pair that enters touching, reported as one blob on its path for ``lead_frames`` frames
    (so one track forms on it), then detected as two pieces ``piece_offset`` either side of that
    path, continuing in two lanes.

    Args:
        rng: The stream's random generator.
        n_events: Instances of the event (>= 1).
        piece_offset: Lateral distance of each piece from the blob's path (m, in (0, 2 mm]).
        **layout: ``lead_frames`` (>= 10 here), ``window``, ``period``
            ([`_layout`][track_envs.streams.merge_events._layout]).
    """
    gap = 2.0 * _gap(piece_offset, "piece_offset", high=2e-3)
    if layout.get("lead_frames", 20) < 10:
        raise ValueError(
            f"lead_frames must be >= 10 for a separation (a track on the blob), got {layout['lead_frames']!r}"
        )
    return _build("separation", rng, n_events, gap, layout)


def missed_pair_stream(
    rng: np.random.Generator,
    *,
    n_events: int = 20,
    lane_gap: tuple[float, float] = (2e-3, 3e-3),
    **layout: int,
) -> MergeEventStream:
    """Two particles side by side, lanes a uniform ``lane_gap[0]``–``lane_gap[1]`` apart (one
    draw per instance), neither detected in one frame.

    Args:
        rng: The stream's random generator.
        n_events: Instances of the event (>= 1).
        lane_gap: Range of the lateral distance of the two lanes (m, ``0 < low <= high <= 4 mm``).
        **layout: ``lead_frames``, ``window``, ``period``
            ([`_layout`][track_envs.streams.merge_events._layout]).
    """
    try:
        low, high = (float(g) for g in lane_gap)
    except (TypeError, ValueError):
        raise ValueError(f"lane_gap must be a pair (low, high) of distances, got {lane_gap!r}") from None
    if not (0.0 < low <= high <= 4e-3):
        raise ValueError(f"lane_gap must satisfy 0 < low <= high <= 0.004 m, got {lane_gap!r}")
    return _build("missed-pair", rng, n_events, (low, high), layout)


def merge_event_streams(rng: np.random.Generator, *, n_events: int = 20) -> dict[str, MergeEventStream]:
    """The three scenarios, each from its own child of ``rng`` (``rng.spawn``), keyed by kind."""
    _check_rng(rng)
    join, separation, missed = rng.spawn(3)
    return {
        "join": join_stream(join, n_events=n_events),
        "separation": separation_stream(separation, n_events=n_events),
        "missed-pair": missed_pair_stream(missed, n_events=n_events),
    }


def _gap(value: float, name: str, high: float = 4e-3) -> float:
    gap = check_positive(name, value)
    if gap > high:
        raise ValueError(f"{name} must be a distance in (0, {high}] m, got {value!r}")
    return gap


def _check_rng(rng: object) -> None:
    if not isinstance(rng, np.random.Generator):
        raise ValueError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")


def _layout(lead_frames: int = 20, window: int = 20, period: int = 10) -> tuple[int, int, int]:
    """Checked layout: ``lead_frames`` from entry to the event (>= 5), the scoring ``window``
    after it (>= 1), ``period`` frames between instance entries (>= 80 / SLOTS so that an
    instance's slot is free again when it is reused); the event and its window must end inside
    the camera window (``lead_frames + window + 2 <= 78`` frames at 5 mm per frame)."""
    lead_frames = check_int("lead_frames", lead_frames, 5)
    window = check_int("window", window, 1)
    span = int(WINDOW_LENGTH / (SPEED * DT))  # frames a particle is in view
    period = check_int("period", period, -(-span // SLOTS))
    if lead_frames + window + 2 > span - 2:
        raise ValueError(
            f"lead_frames + window must be <= {span - 6} (the event and its window inside the camera "
            f"window), got lead_frames={lead_frames}, window={window}"
        )
    return lead_frames, window, period


def _build(
    kind: str,
    rng: np.random.Generator,
    n_events: int,
    gap: float | tuple[float, float],
    layout: dict[str, int],
) -> MergeEventStream:
    _check_rng(rng)
    n_events = check_int("n_events", n_events, 1)
    unknown = set(layout) - {"lead_frames", "window", "period"}
    if unknown:
        raise ValueError(f"unknown layout argument(s) {sorted(unknown)}; valid: lead_frames, window, period")
    lead, window, period = _layout(**layout)
    spec = belt_spec()
    e = n_events
    entry = np.arange(e, dtype=np.int64) * period
    event = entry + lead
    frames = int(event[-1]) + window + 2
    # the instances' geometry, one vectorised draw per quantity
    gaps = np.full(e, gap) if np.isscalar(gap) else rng.uniform(gap[0], gap[1], e)  # type: ignore[index]
    centre = SLOT_PITCH * (1.5 + np.arange(e) % SLOTS) + rng.uniform(-2e-3, 2e-3, e)
    x0 = rng.uniform(2e-4, 3e-3, e)  # both of the pair in view from the entry frame
    vx = SPEED * (1.0 + rng.uniform(-0.02, 0.02, e))
    vy = rng.uniform(-0.01, 0.01, e)
    dx = rng.uniform(-2e-4, 2e-4, e)
    side = rng.choice([-1.0, 1.0], e)
    neighbour_dy = side * (gaps / 2 + rng.uniform(4e-3, 6e-3, e))
    neighbour_dx = rng.uniform(-3e-3, 3e-3, e)
    neighbour_vx = vx * (1.0 + rng.uniform(-0.01, 0.01, e))  # a parallel lane, a little faster or slower
    follower_lane = rng.choice([-0.5, 0.5], e)
    follower_dx = -rng.uniform(10e-3, 20e-3, e)
    start = np.empty((e, PER_INSTANCE, 2))
    start[:, 0] = np.stack([x0 + dx / 2, centre - gaps / 2], 1)
    start[:, 1] = np.stack([x0 - dx / 2, centre + gaps / 2], 1)
    start[:, 2] = np.stack([x0 + neighbour_dx, centre + neighbour_dy], 1)
    start[:, 3] = np.stack([x0 + follower_dx, centre + follower_lane * gaps], 1)
    velocity = np.repeat(np.stack([vx, vy], 1)[:, None], PER_INSTANCE, 1)
    velocity[:, 2, 0] = neighbour_vx
    t = np.arange(frames)[:, None, None]
    positions = start.reshape(1, -1, 2) + velocity.reshape(1, -1, 2) * DT * (
        t - np.repeat(entry, 4)[None, :, None]
    )
    n = PER_INSTANCE * e
    inside = (positions >= 0.0) & (positions <= np.array([WINDOW_LENGTH, WINDOW_WIDTH]))
    visible = inside.all(axis=2) & (t[:, :, 0] >= np.repeat(entry, 4)[None])
    group = np.broadcast_to(np.arange(n), (frames, n)).copy()  # the blob each particle is in
    detected = visible.copy()
    a, b = PER_INSTANCE * np.arange(e), PER_INSTANCE * np.arange(e) + 1
    if kind == "join":
        group[event, b] = a
    elif kind == "missed-pair":
        detected[event, a] = detected[event, b] = False
    else:  # separation: one blob from entry until the event frame
        rows = (entry[:, None] + np.arange(lead)).ravel()
        group[rows, np.repeat(b, lead)] = np.repeat(a, lead)
    detections, mask, ids = _detect(rng, positions, detected, group, spec)
    return MergeEventStream(
        kind=kind,
        spec=spec,
        detections=detections,
        mask=mask,
        detection_ids=ids,
        truth_ids=np.arange(n, dtype=np.int64),
        positions=positions,
        visible=visible,
        event_frames=event,
        involved=np.stack([a, b], 1).astype(np.int64),
        entry_frames=entry,
        lane_gap=float(np.mean(gaps)),
    )


def _detect(
    rng: np.random.Generator,
    positions: NDArray[np.float64],
    detected: NDArray[np.bool_],
    group: NDArray[np.int64],
    spec: SensorSpec,
) -> tuple[NDArray[np.float32], NDArray[np.int8], NDArray[np.int64]]:
    """Per frame, one detection per blob (the mean of its detected particles, plus N(0, σ²I)
    noise), rows in random order, zero padded; and the truth ids behind each row."""
    frames, _, dim = positions.shape
    out = np.zeros((frames, spec.max_detections, dim), np.float32)
    mask = np.zeros((frames, spec.max_detections), np.int8)
    ids = np.full((frames, spec.max_detections, 2), -1, np.int64)
    for t in range(frames):
        members = np.flatnonzero(detected[t])
        blobs, inverse, size = np.unique(group[t, members], return_inverse=True, return_counts=True)
        m = len(blobs)
        if m > spec.max_detections:
            raise ValueError(f"frame {t} has {m} detections, more than max_detections={spec.max_detections}")
        centroid = np.zeros((m, dim))
        np.add.at(centroid, inverse, positions[t, members])
        centroid /= size[:, None]
        centroid += rng.normal(0.0, spec.noise_std, (m, dim))
        order = rng.permutation(m)
        out[t, :m] = centroid[order]
        mask[t, :m] = 1
        # the row's ids: the blob's label (its first particle) and the other member, if any
        second = np.full(m, -1, np.int64)
        others = members[members != group[t, members]]
        second[np.searchsorted(blobs, group[t, others])] = others
        ids[t, :m, 0] = blobs[order]
        ids[t, :m, 1] = second[order]
    return out, mask, ids
