"""Constant-velocity point targets crossing a 2-D window, with misses and clutter.

The targets are a stationary field of straight-line movers seen through the observed region
``[0, L] × [0, W]`` (metres): each moves at its own constant velocity ``v ~ N(v̄, diag(s²))``
(cut at ``v̄ ± 6 s``), and their density ``ρ = N / (L W)`` is uniform, so that ``N`` targets are
in view on average (the count of a frame is Poisson). Frame 0 holds ``Poisson(N)`` targets
uniform over the window. Every later frame, the targets that crossed into the window through
each edge (inward normal ``n``) arrive as a Poisson number with mean

.. math::

    μ_n = ρ \\, dt \\, \\ell_n \\, E[(n \\cdot v)^+], \\qquad
    E[X^+] = μ Φ(μ/s) + s φ(μ/s) \\text{ for } X \\sim N(μ, s^2),

(``ℓ_n`` the edge's length), uniform along the edge, with velocities drawn in proportion to
``(n·v)⁺ p(v)`` (the flux through the edge) and carried on from the edge for a uniform share of
the frame; a target that leaves the window never returns. The field therefore stays uniform at
density ``ρ``: ``v̄ = (1, 0)`` with a small ``s`` is a belt's flow (entries upstream, exits
downstream), ``v̄ = 0`` with ``s > 0`` targets in every direction.

Every frame, the point sensor of the environments
([`track_envs.envs.sensors.sense_points`][track_envs.envs.sensors.sense_points]) sees the targets inside the
window: each is detected with probability ``p_D``, with Gaussian noise ``σ`` per axis, and ``Poisson(λ)``
clutter detections fall uniformly over the window; the rows are shuffled and padded. The defaults are the
belt's scale — ``dt = 0.01`` s, ``v̄ = (1, 0)`` m/s, ``s = (0.05, 0.05)`` m/s, ``σ = 0.1`` mm, a 0.5 m × 0.3 m
window — with ``N = 150``, ``p_D = 0.9`` and ``λ = 5``: targets about 3 cm apart that move 1 cm per frame and
stay in view for ≈50 frames.

[`score_tracker`][track_envs.streams.score_tracker] runs a tracker over a stream and scores its reports with
the environments' point metrics: CLEAR MOT and IDF1 ([`ClearMot`][track_envs.metrics.ClearMot])
and HOTA ([`Hota`][track_envs.metrics.Hota]), match distance ``c`` (default 5 mm,
the belt's GOSPA cut-off).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from track_envs.envs.sensors import sense_points
from track_envs.infra.arguments import check_int, check_non_negative, check_positive, check_probability
from track_envs.metrics.base import Metric
from track_envs.metrics.clear_mot import ClearMot
from track_envs.metrics.hota_stream import Hota
from track_envs.values.types import SensorSpec

#: Velocities are drawn from a Gaussian cut at this many standard deviations of the mean.
TAIL_SIGMAS = 6.0


class ConstantVelocityStream(NamedTuple):
    """A synthetic stream and its truth.

    Attributes:
        spec: The sensor: the window, ``dt``, ``noise_std``, ``p_detect``, ``clutter_rate``;
            ``max_detections`` and ``max_tracks`` with room for every frame.
        observations: One ``{"detections": (max_detections, 2) float32, "mask": (max_detections,)
            int8}`` per frame, rows shuffled.
        truth_ids: Per frame, the ids (n_t,) int64 of the targets inside the window.
        truth_positions: Per frame, their positions (n_t, 2) float64.
        detection_ids: Per frame, the truth id (max_detections,) int64 behind each observation row:
            −1 for clutter and padding.
    """

    spec: SensorSpec
    observations: list[dict[str, NDArray[Any]]]
    truth_ids: list[NDArray[np.int64]]
    truth_positions: list[NDArray[np.float64]]
    detection_ids: list[NDArray[np.int64]]

    def truth(self, frame: int) -> dict[str, NDArray[Any]]:
        """``info["truth"]`` of ``frame`` as the environments give it (ids, positions, visible)."""
        ids = self.truth_ids[frame]
        return {
            "ids": ids,
            "positions": self.truth_positions[frame],
            "visible": np.ones(len(ids), dtype=np.bool_),
        }


#: The default scene's targets in view, window ``(L, W)`` (m) and clutter per frame.
DEFAULT_TARGETS, DEFAULT_SIZE, DEFAULT_CLUTTER = 150.0, (0.5, 0.3), 5.0


def constant_density(n_targets: float) -> dict[str, Any]:
    """Keyword arguments of [`constant_velocity_stream`][track_envs.streams.constant_velocity_stream] for
    ``n_targets`` in view at the default scene's densities: the window grows with ``s = √(N / 150)`` to
    ``(0.5 s, 0.3 s)`` m and the clutter to ``5 N / 150`` per frame, so targets stay ≈3 cm apart and clutter
    per area is the default's::

        constant_velocity_stream(rng, **constant_density(100_000), frames=50)

    Generation is linear in the targets: ≈0.2–0.3 µs per target and frame (``N`` = 10³–10⁵), and
    the stream holds ≈40 bytes per target and frame (4 MB per frame at ``N = 10⁵``).

    Raises:
        ValueError: if ``n_targets`` is not a finite number > 0.
    """
    n = check_positive("n_targets", n_targets)
    scale = math.sqrt(n / DEFAULT_TARGETS)
    return {
        "n_targets": n,
        "size": (DEFAULT_SIZE[0] * scale, DEFAULT_SIZE[1] * scale),
        "clutter_rate": DEFAULT_CLUTTER * n / DEFAULT_TARGETS,
    }


def constant_velocity_stream(
    rng: np.random.Generator,
    *,
    n_targets: float = 150.0,
    frames: int = 500,
    p_detect: float = 0.9,
    clutter_rate: float = 5.0,
    noise_std: float = 1e-4,
    dt: float = 0.01,
    size: Sequence[float] = (0.5, 0.3),
    velocity: Sequence[float] = (1.0, 0.0),
    velocity_std: Sequence[float] = (0.05, 0.05),
) -> ConstantVelocityStream:
    """Draw a stream of constant-velocity targets crossing a window (see the module docstring).

    Args:
        rng: The generator every draw comes from (a seed fixes the stream bit for bit).
        n_targets: ``N``, the mean number of targets in view, > 0.
        frames: Frames of the stream, >= 1.
        p_detect: ``p_D``, in [0, 1].
        clutter_rate: ``λ``, mean clutter detections per frame, >= 0.
        noise_std: ``σ``, measurement noise std per axis (m), >= 0.
        dt: Frame period (s), > 0.
        size: ``(L, W)``, the window's extent along x and y (m), each > 0.
        velocity: ``v̄``, the mean velocity (m/s), finite.
        velocity_std: ``s``, the velocity std per axis (m/s), each >= 0, not both 0 when
            ``v̄ = 0`` (no target would enter).

    Returns:
        [`ConstantVelocityStream`][track_envs.streams.ConstantVelocityStream]
            ``(spec, observations, truth_ids, truth_positions, detection_ids)``.

    Raises:
        ValueError: naming the argument, its value and the valid range.
    """
    if not isinstance(rng, np.random.Generator):
        raise ValueError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
    n_targets = check_positive("n_targets", n_targets)
    frames = check_int("frames", frames, 1)
    p_detect = check_probability("p_detect", p_detect)
    clutter_rate = check_non_negative("clutter_rate", clutter_rate)
    noise_std = check_non_negative("noise_std", noise_std)
    dt = check_positive("dt", dt)
    extent = np.array(_pair("size", size, check_positive))
    v_mean = np.array(_pair("velocity", velocity, _finite))
    v_std = np.array(_pair("velocity_std", velocity_std, check_non_negative))
    if not np.any(np.abs(v_mean) + v_std > 0):
        raise ValueError(
            f"velocity={velocity!r} and velocity_std={velocity_std!r} leave every target still: "
            "no target would ever enter the window; give a non-zero mean or spread"
        )
    flow = _Flow(rng, n_targets / float(np.prod(extent)), extent, v_mean, v_std, dt)
    low, high = np.zeros(2), extent

    x, v = flow.initial()
    ids = np.arange(len(x), dtype=np.int64)
    next_id = len(x)
    frame_z: list[NDArray[np.float64]] = []
    frame_source: list[NDArray[np.int64]] = []
    truth_ids: list[NDArray[np.int64]] = []
    truth_positions: list[NDArray[np.float64]] = []
    for t in range(frames):
        if t:
            x = x + v * dt
            x_new, v_new = flow.entries()
            x, v = np.concatenate([x, x_new]), np.concatenate([v, v_new])
            ids = np.concatenate([ids, np.arange(next_id, next_id + len(x_new), dtype=np.int64)])
            next_id += len(x_new)
            inside = np.all((x >= low) & (x <= high), axis=1)  # a target that left never returns
            x, v, ids = x[inside], v[inside], ids[inside]
        truth_ids.append(ids)
        truth_positions.append(x)
        z, source = sense_points(
            x,
            ids,
            rng,
            noise_std=noise_std,
            p_detect=p_detect,
            clutter_rate=clutter_rate,
            clutter_low=low,
            clutter_high=high,
        )
        order = rng.permutation(len(z))
        frame_z.append(z[order])
        frame_source.append(source[order])

    most = max(len(z) for z in frame_z)
    spec = SensorSpec(
        dt=dt,
        dim=2,
        noise_std=noise_std,
        p_detect=p_detect,
        clutter_rate=clutter_rate,
        region_low=(0.0, 0.0),
        region_high=(float(extent[0]), float(extent[1])),
        max_detections=max(most, 1),
        max_tracks=max(4 * most, 16),
    )
    observations: list[dict[str, NDArray[Any]]] = []
    detection_ids: list[NDArray[np.int64]] = []
    for z, source in zip(frame_z, frame_source, strict=True):
        det = np.zeros((spec.max_detections, 2), dtype=np.float32)
        mask = np.zeros(spec.max_detections, dtype=np.int8)
        rows = np.full(spec.max_detections, -1, dtype=np.int64)
        det[: len(z)], mask[: len(z)], rows[: len(z)] = z, 1, source
        observations.append({"detections": det, "mask": mask})
        detection_ids.append(rows)
    return ConstantVelocityStream(spec, observations, truth_ids, truth_positions, detection_ids)


class _Flow:
    """The stationary field of straight-line targets seen through the window: its state at frame 0
    and the targets that cross into the window during a frame (module docstring)."""

    def __init__(
        self,
        rng: np.random.Generator,
        density: float,
        extent: NDArray[np.float64],
        v_mean: NDArray[np.float64],
        v_std: NDArray[np.float64],
        dt: float,
    ) -> None:
        self.rng, self.density, self.extent, self.dt = rng, density, extent, dt
        self.v_mean, self.v_std = v_mean, v_std
        # the edges: (axis, inward sign); the inward flux per unit length ρ E[(n·v)⁺] of each
        self.edges = [(axis, sign) for axis in range(2) for sign in (1.0, -1.0)]
        self.mean_entries = [
            density * dt * extent[1 - axis] * _positive_part_mean(sign * v_mean[axis], v_std[axis])
            for axis, sign in self.edges
        ]

    def velocities(self, k: int) -> NDArray[np.float64]:
        """``k`` velocities ``N(v̄, diag(s²))`` cut at ``v̄ ± 6 s``."""
        eps = np.clip(self.rng.standard_normal((k, 2)), -TAIL_SIGMAS, TAIL_SIGMAS)
        return self.v_mean + self.v_std * eps

    def initial(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Frame 0: ``Poisson(N)`` targets uniform over the window."""
        k = int(self.rng.poisson(self.density * float(np.prod(self.extent))))
        return self.rng.random((k, 2)) * self.extent, self.velocities(k)

    def entries(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The targets that crossed an edge during the last frame, at their positions now."""
        xs, vs = [], []
        for (axis, sign), mean in zip(self.edges, self.mean_entries, strict=True):
            k = int(self.rng.poisson(mean)) if mean > 0 else 0
            if not k:
                continue
            v = self._flux_weighted(k, axis, sign)
            x = np.empty((k, 2))
            x[:, 1 - axis] = self.rng.random(k) * self.extent[1 - axis]
            x[:, axis] = 0.0 if sign > 0 else self.extent[axis]
            x += v * (self.dt * self.rng.random(k))[:, None]  # crossed at a uniform time in the frame
            xs.append(x)
            vs.append(v)
        if not xs:
            return np.zeros((0, 2)), np.zeros((0, 2))
        return np.concatenate(xs), np.concatenate(vs)

    def _flux_weighted(self, k: int, axis: int, sign: float) -> NDArray[np.float64]:
        """``k`` velocities drawn with density ∝ ``(n·v)⁺ p(v)`` (rejection from ``p``)."""
        bound = max(sign * self.v_mean[axis] + TAIL_SIGMAS * self.v_std[axis], 1e-300)
        out: list[NDArray[np.float64]] = []
        have = 0
        while have < k:
            v = self.velocities(2 * (k - have) + 8)
            speed_in = np.maximum(sign * v[:, axis], 0.0)
            v = v[self.rng.random(len(v)) * bound < speed_in]
            out.append(v)
            have += len(v)
        return np.concatenate(out)[:k]


def _positive_part_mean(mu: float, s: float) -> float:
    """``E[X⁺]`` for ``X ~ N(μ, s²)``: ``μ Φ(μ/s) + s φ(μ/s)`` (``max(μ, 0)`` when ``s = 0``)."""
    if s == 0:
        return max(mu, 0.0)
    a = mu / s
    return mu * 0.5 * math.erfc(-a / math.sqrt(2.0)) + s * math.exp(-0.5 * a * a) / math.sqrt(2.0 * math.pi)


def score_tracker(
    agent: Any, stream: ConstantVelocityStream, *, threshold: float = 0.005, seed: int = 0
) -> dict[str, float]:
    """Run ``agent`` (``reset(spec, seed=)``, ``act(obs) -> report``) over ``stream`` and score it.

    Args:
        agent: A tracker.
        stream: The stream ([`constant_velocity_stream`][track_envs.streams.constant_velocity_stream]).
        threshold: ``c``, the match distance of CLEAR MOT / IDF1 and HOTA's zero-similarity
            distance (m), > 0.
        seed: Passed to ``agent.reset``.

    Returns:
        [`ClearMot.compute`][track_envs.metrics.ClearMot.compute]'s figures
            (``mota``, ``idf1``, ``id_switches``, ...) and [`Hota`][track_envs.metrics.Hota]'s
            (``hota``, ``det_a``, ``ass_a``, ...).
    """
    threshold = check_positive("threshold", threshold)
    metrics: list[Metric] = [ClearMot(threshold=threshold), Hota(threshold=threshold)]
    agent.reset(stream.spec, seed=seed)
    for frame, obs in enumerate(stream.observations):
        report = agent.act(obs)
        truth = stream.truth(frame)
        for metric in metrics:
            metric.update(truth, stream.detection_ids[frame], report)
    figures: dict[str, float] = {}
    for metric in metrics:
        figures.update({k: float(v) for k, v in metric.compute().items()})
    return figures


def _finite(name: str, value: Any) -> float:
    if (
        isinstance(value, bool)
        or not isinstance(value, int | float | np.integer | np.floating)
        or not math.isfinite(value)
    ):
        raise ValueError(f"{name} must be a finite number, got {value!r}")
    return float(value)


def _pair(name: str, value: Any, check: Any) -> tuple[float, float]:
    """``value`` as two numbers, each passing ``check(name[i], v)``."""
    items = value.tolist() if isinstance(value, np.ndarray) else value
    if isinstance(items, str) or not isinstance(items, Sequence) or len(items) != 2:
        raise ValueError(f"{name} must be two numbers (x, y), got {value!r}")
    return check(f"{name}[0]", items[0]), check(f"{name}[1]", items[1])
