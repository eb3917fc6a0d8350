"""The sensor model estimate: the sensor and motion noise of a Kalman tracker estimated from its own
tracks.

[`estimate_sensor_model`][agents.estimate_sensor_model] needs nothing but the detections and the frame period.
It iterates

1. **first settings from the data** ([`agents.sensor_model.scales`][agents.sensor_model.scales]): the flow
``ū`` and
   spread ``s`` of the frame-to-frame displacements give the measurement noise std ``s / 2``, a
   process noise whose one-frame position std is ``s``, a velocity prior ``N(ū / dt, (2 s / dt)²)``
   and an acceleration std ``2 s / dt²``;
2. **track** the stream with the GNN tracker and the chosen Kalman model ([`agents.gnn`][agents.gnn]);
3. **estimate** from the confident tracks (at least ``MIN_TRACK_LENGTH`` detections) the
   measurement variance ``r`` and the process-noise intensity ``q`` of the model by autocovariance
   least squares on the differenced detections ([`agents.sensor_model.noise`][agents.sensor_model.noise];
   Odelson, Rajamani and Rawlings 2006), and the velocity prior — median and robust spread of each track's
   first velocity — and, for the constant-acceleration model, the spread of the first accelerations;
4. **estimate** from the same confident tracks the detection probability ``p_D`` (their gaps)
   and the clutter density ``λ`` (the detections none of them claims, per unit area and frame):
   [`agents.sensor_model.detection`][agents.sensor_model.detection]; the next run's sensor is told them, so
   that gnn's second chance weighs a coasting track against clutter, ``(p_D − a) N(z) ≥ (1 − p_D) λ``;
5. **repeat** 2–4 with the new settings until ``r`` and ``q`` change by less than ``SETTLED``
   (relative) or ``max_iterations`` runs were made;
6. from the last run: the coasting length ([`agents.sensor_model.coasting`][agents.sensor_model.coasting]) and
jpda's merge
   extent ([`agents.sensor_model.merging`][agents.sensor_model.merging]: the boxes' size, or the closest
   approaches of the confident track pairs).

The tracking runs work on the detections divided by a power of two near the stream's length
``ℓ`` (exact in floating point), so the filters' absolute floors (``R >= 1e-12``) never meet the
data, and every estimate is a second moment of positions: positions × k give ``σ`` × k, ``q`` × k²,
velocities × k, ``λ`` × k^−D, the merge extent × k and ``p_D`` as it is — the same tracks in
pixels and in metres.

Floors, relative to the data: ``σ >= 1e-3 ℓ`` and a process noise whose one-frame position variance
is at least ``MIN_PROCESS_SHARE`` of ``r`` (a filter that believes its targets never deviate from
the model stops following them).
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agents.base import make_agent
from agents.files.loop import track_detections
from agents.sensor_model.coasting import coasting_radii, reappearance_gaps
from agents.sensor_model.detection import DetectionModel, detection_model
from agents.sensor_model.diagnostics import count_distinct
from agents.sensor_model.merging import merge_extent as estimate_merge_extent
from agents.sensor_model.noise import NoiseEstimate, estimate_noise
from agents.sensor_model.scales import DataScales, data_scales
from predictors import make_predictor
from predictors.base import Capability, KinematicModel, capability
from track_envs.values.detections import Detections
from track_envs.values.tracks import Tracks
from track_envs.values.types import SensorSpec

#: The predictor whose kinematic model serves the estimate for a predictor that declares none
#: (``Capability.KINEMATIC_MODEL``): only its measurement noise (the sensor spec's) is then used.
FALLBACK_PREDICTOR = "kf-cv"
#: The name of each kinematic order
#: ([`SensorModelEstimate.model`][agents.sensor_model.estimate.SensorModelEstimate.model]).
MODEL_NAMES: dict[int, str] = {1: "random-walk", 2: "cv", 3: "ca"}
#: Fewest detections of a track that the estimate takes.
MIN_TRACK_LENGTH = 6
#: Relative change of ``r`` and ``q`` under which the iteration stops.
SETTLED = 0.1
#: Least one-frame process position variance, as a share of ``r``.
MIN_PROCESS_SHARE = 0.01
#: Frames into a track its first velocity (and acceleration) are taken over.
START_SPAN = 3
#: The gate probability of the tracker (its default), for the printed gate radius.
DEFAULT_P_GATE = 0.999
#: Fewest frames a track may coast (the gnn's default).
MIN_MAX_MISSES = 2
#: Most frames a track may coast.
MAX_MAX_MISSES = 100
#: Share of track ends whose target re-appears
#: ([`agents.sensor_model.coasting`][agents.sensor_model.coasting]) from which
#: tracks coast through the longest gap seen.
REAPPEAR_SHARE = 0.05


@dataclass(frozen=True)
class Settings:
    """Tracker settings in input units: noise std, ``q``, velocity prior, acceleration std."""

    noise_std: float
    q: float
    velocity_mean: NDArray[np.float64]
    velocity_std: float
    acceleration_std: float

    def scaled(self, k: float) -> Settings:
        """The settings for positions × ``k`` (``q`` is a variance intensity: × k²)."""
        return Settings(
            self.noise_std * k,
            self.q * k * k,
            self.velocity_mean * k,
            self.velocity_std * k,
            self.acceleration_std * k,
        )


@dataclass(frozen=True)
class SensorModelEstimate:
    """What [`estimate_sensor_model`][agents.estimate_sensor_model] estimated, in the units of the input
    (positions as given, seconds).

    Attributes:
        dt: Frame period (s).
        predictor: The predictor the settings are for; ``model`` its Kalman model.
        noise_std: Measurement noise std per axis ``σ`` (the tracker's ``R = σ² I``).
        q: Process-noise intensity of the model (units² / s³ for cv, / s⁵ for ca, / s for random-walk).
        velocity_mean: (D,) mean velocity of a new track (units / s).
        velocity_std: Std of a new track's velocity per axis (units / s).
        acceleration_std: Std of a new track's acceleration (units / s²; used by ca).
        p_gate: Gate probability; ``gate_radius`` the χ² gate at the steady-state innovation of a
            track updated every frame, as a distance (units).
        length: The stream's median nearest-neighbour distance within a frame (units).
        flow: (D,) most common displacement per frame (units).
        threshold: The default metric match distance, ``length / 2`` (units).
        max_misses: Frames a track may coast: when at least ``REAPPEAR_SHARE`` of the confident
            tracks' ends are followed by a start of the same target (their re-appearances,
            `agents.sensor_model.coasting`, looked for while the coasted gate
            radius stays within ``length / 2``), the longest gap of those; else ``MIN_MAX_MISSES``.
        reappearing: That share; ``reappearance_gaps``: the gaps seen (frames).
        iterations: Tracking runs made; ``settled``: whether ``r`` and ``q`` settled.
        n_tracks: Confident tracks of the last estimate; ``n_differences``: differences it used.
        p_detect: ``p_D``, the detection probability
            (`agents.sensor_model.detection`: from the ``n_gaps`` gaps of the
            confident tracks; 1 without any).
        clutter_density: ``λ``, clutter detections per unit area (input units^D) and frame: the
            ``n_unclaimed`` detections no confident track claims over ``clutter_area`` (the area
            the detections cover, input units^D) and the frames; 0 without an area.
        merge_extent: jpda's merge extent (input units;
            `agents.sensor_model.merging`), by ``merge_rule`` (``"boxes"``,
            ``"closest approaches"``, ``"given"``); None: no merge model (rule ``"none"``).
        sources: For each setting, ``"estimated"`` or ``"given"``.
        history: ``(σ, q)`` after each run.
    """

    dt: float
    predictor: str
    model: str
    noise_std: float
    q: float
    velocity_mean: tuple[float, ...]
    velocity_std: float
    acceleration_std: float
    p_gate: float
    gate_radius: float
    length: float
    flow: tuple[float, ...]
    threshold: float
    max_misses: int
    reappearing: float
    reappearance_gaps: tuple[int, ...]
    iterations: int
    settled: bool
    n_tracks: int
    n_differences: int
    p_detect: float = 1.0
    n_gaps: int = 0
    clutter_density: float = 0.0
    n_unclaimed: int = 0
    clutter_area: float = 0.0
    merge_extent: float | None = None
    merge_rule: str = "none"
    sources: dict[str, str] = field(default_factory=dict)
    history: tuple[tuple[float, float], ...] = ()

    def agent_kwargs(self, agent: str = "gnn") -> dict[str, Any]:
        """``make_agent(agent, predictor=..., **kwargs)`` keywords that carry the settings (the
        measurement noise, ``p_D`` and ``λ`` go in the sensor spec,
        [`sensor_spec`][agents.SensorModelEstimate.sensor_spec]); empty for a predictor without a kinematic
        model (`kinematics`). For ``agent="jpda"`` also its
        ``merge_extent`` (or ``merge_model=False`` where none was found)."""
        merge: dict[str, Any] = {}
        if agent == "jpda":
            merge = (
                {"merge_model": False} if self.merge_extent is None else {"merge_extent": self.merge_extent}
            )
        if kinematics(self.predictor) is None:
            return merge
        kwargs: dict[str, Any] = merge | {"q": self.q, "max_misses": self.max_misses}
        if self.model != "random-walk":
            kwargs |= {
                "initial_velocity": np.array(self.velocity_mean),
                "initial_velocity_std": self.velocity_std,
                "velocity_fallback": np.array(self.velocity_mean),
            }
        if self.model == "ca":
            kwargs["initial_acceleration_std"] = self.acceleration_std
        return kwargs

    def sensor_spec(self, spec: SensorSpec) -> SensorSpec:
        """``spec`` with the estimated measurement noise std, ``p_detect`` and the clutter rate of
        density ``λ`` over ``spec``'s region (``λ`` × its volume: trackers read ``λ`` as
        ``clutter_rate`` / the region's volume)."""
        return with_detection_model(
            dataclasses.replace(spec, noise_std=self.noise_std), self.p_detect, self.clutter_density
        )

    def as_dict(self) -> dict[str, Any]:
        """A JSON-ready dict (units: those of the input, seconds)."""
        out = dataclasses.asdict(self)
        out["velocity_mean"] = list(self.velocity_mean)
        out["flow"] = list(self.flow)
        out["history"] = [list(h) for h in self.history]
        out["units"] = "input units (positions as given after --scale), seconds"
        return out


def with_detection_model(spec: SensorSpec, p_detect: float, clutter_density: float) -> SensorSpec:
    """``spec`` telling ``p_detect`` and clutter of density ``clutter_density`` over its region
    (its own ``clutter_rate`` kept where it already tells that density, so that a declared rate
    is not rounded through the density)."""
    rate = clutter_density * float(np.prod(spec.region_size))
    if math.isclose(rate, spec.clutter_rate, rel_tol=1e-12, abs_tol=0.0):
        rate = spec.clutter_rate
    return dataclasses.replace(spec, p_detect=float(p_detect), clutter_rate=float(rate))


@functools.lru_cache(maxsize=16)
def kinematics(predictor: str) -> KinematicModel | None:
    """The kinematic model of the predictor registered as ``predictor`` (its
    ``Capability.KINEMATIC_MODEL``; the predictor is built once), ``None`` where it declares none.

    Raises:
        ValueError: for an unknown predictor name (listing the registered ones).
    """
    return capability(make_predictor(predictor), Capability.KINEMATIC_MODEL)


def tracking_model(predictor: str) -> tuple[str, KinematicModel]:
    """The predictor the tracking runs use and its kinematic model: ``predictor`` itself where it
    has one ([`kinematics`][agents.sensor_model.estimate.kinematics]), else
    [`FALLBACK_PREDICTOR`][agents.sensor_model.estimate.FALLBACK_PREDICTOR]."""
    own = kinematics(predictor)
    if own is not None:
        return predictor, own
    fallback = kinematics(FALLBACK_PREDICTOR)
    assert fallback is not None, f"{FALLBACK_PREDICTOR} declares no kinematic model"
    return FALLBACK_PREDICTOR, fallback


def first_settings(scales: DataScales, dt: float, order: int) -> Settings:
    """The settings of the first run from the stream's scales (module docstring, step 1)."""
    s = scales.spread
    m = order
    # one-frame position variance of the process noise: q dt^(2m−1) / ((2m−1) ((m−1)!)²) = s²
    q = s * s * (2 * m - 1) * math.factorial(m - 1) ** 2 / dt ** (2 * m - 1)
    return Settings(
        noise_std=s / 2,
        q=q,
        velocity_mean=scales.flow / dt,
        velocity_std=2 * s / dt,
        acceleration_std=2 * s / dt**2,
    )


def detection_labels(detections: Detections, tracks: Tracks) -> NDArray[np.int64]:
    """(N,) the id of the track each detection updated (−1: none)."""
    labels = np.full(len(detections), -1, np.int64)
    if tracks.detection is None or not len(tracks):
        return labels
    used = tracks.detection >= 0
    rows = detections.offsets[tracks.frame[used]] + tracks.detection[used]
    labels[rows] = tracks.ids[used]
    return labels


def confident(labels: NDArray[np.int64], min_length: int = MIN_TRACK_LENGTH) -> NDArray[np.int64]:
    """``labels`` with the tracks of fewer than ``min_length`` detections set to −1."""
    out = labels.copy()
    ok = labels >= 0
    if not ok.any():
        return out
    ids, inverse, counts = np.unique(labels[ok], return_inverse=True, return_counts=True)
    del ids
    short = counts[inverse] < min_length
    idx = np.flatnonzero(ok)[short]
    out[idx] = -1
    return out


def start_motion(
    points: NDArray[np.float64], frames: NDArray[np.int64], labels: NDArray[np.int64], dt: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]] | None:
    """Each labelled track's first velocity and acceleration ((T, D) each), from its detections
    ``0``, ``j`` and ``2 j`` (``j = START_SPAN``) by divided differences over their times; None
    without tracks of ``2 j + 1`` detections."""
    idx = np.flatnonzero(labels >= 0)
    idx = idx[np.lexsort((frames[idx], labels[idx]))]
    lab = labels[idx]
    first = np.flatnonzero(np.concatenate([[True], lab[1:] != lab[:-1]]))
    ends = np.concatenate([first[1:], [len(lab)]])
    j = START_SPAN
    first = first[ends - first > 2 * j]
    if not len(first):
        return None
    i0, i1, i2 = idx[first], idx[first + j], idx[first + 2 * j]
    t0, t1, t2 = (frames[i] * dt for i in (i0, i1, i2))
    v01 = (points[i1] - points[i0]) / (t1 - t0)[:, None]
    v12 = (points[i2] - points[i1]) / (t2 - t1)[:, None]
    return v01, 2 * (v12 - v01) / (t2 - t0)[:, None]


def _robust(values: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Median and (1.4826 MAD)² per column."""
    med = np.median(values, axis=0)
    return med, (1.4826 * np.median(np.abs(values - med), axis=0)) ** 2


def estimate_settings(
    detections: Detections, labels: NDArray[np.int64], dt: float, order: int, length: float, before: Settings
) -> tuple[Settings, NoiseEstimate] | None:
    """New settings from the confident tracks of ``labels`` (module docstring, step 3)."""
    frames = detections.frame_index()
    sure = confident(labels)
    noise = estimate_noise(detections.points, frames, sure, dt, order)
    if noise is None:
        return None
    r = max(noise.r, (1e-3 * length) ** 2)
    m = order
    q_floor = MIN_PROCESS_SHARE * r * (2 * m - 1) * math.factorial(m - 1) ** 2 / dt ** (2 * m - 1)
    q = max(noise.q, q_floor)
    motion = start_motion(detections.points, frames, sure, dt)
    velocity_mean, velocity_std, acceleration_std = (
        before.velocity_mean,
        before.velocity_std,
        before.acceleration_std,
    )
    if motion is not None and len(motion[0]) >= 3:
        v, a = motion
        velocity_mean, v_var = _robust(v)
        # the first velocity is measured with variance 2 r / (j dt)²: a floor, not removed
        velocity_std = float(np.sqrt(np.max(v_var) + 2 * r / (START_SPAN * dt) ** 2))
        a_mean, a_var = _robust(a)
        a_noise = 6 * r / (START_SPAN * dt) ** 4  # the divided difference's own noise variance
        a_var = np.maximum(a_var - a_noise, 0.25 * a_var)
        acceleration_std = float(np.sqrt(np.max(a_mean**2 + a_var)))
        if not acceleration_std > 0:
            acceleration_std = before.acceleration_std
    return Settings(
        float(np.sqrt(r)), float(q), np.asarray(velocity_mean, np.float64), velocity_std, acceleration_std
    ), noise


def _power_of_two(x: float) -> float:
    return float(2.0 ** round(math.log2(x)))


def _run_gnn(
    detections: Detections,
    spec: SensorSpec,
    predictor: str,
    settings: Settings,
    agent_kwargs: Mapping[str, Any],
) -> Tracks:
    """One tracking run of the gnn with ``settings`` (the stream and settings already normalised)."""
    name, kinematic = tracking_model(predictor)
    model = MODEL_NAMES[kinematic.order]
    kwargs: dict[str, Any] = {"q": settings.q}
    if model != "random-walk":
        kwargs |= {
            "initial_velocity": settings.velocity_mean,
            "initial_velocity_std": settings.velocity_std,
            "velocity_fallback": settings.velocity_mean,
        }
    if model == "ca":
        kwargs["initial_acceleration_std"] = settings.acceleration_std
    kwargs = kwargs | dict(agent_kwargs) | {"predict_sorting": False}
    agent = make_agent("gnn", predictor=name, **kwargs)
    run_spec = dataclasses.replace(spec, noise_std=settings.noise_std, sorting_line=None)
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # a report grown in a trial run says nothing
        return track_detections(agent, detections, run_spec, seed=0)  # type: ignore[return-value]


def estimate_sensor_model(
    detections: Detections,
    spec: SensorSpec,
    *,
    predictor: str = "kf-ca",
    noise_std: float | None = None,
    q: float | None = None,
    velocity_mean: NDArray[np.floating] | None = None,
    velocity_std: float | None = None,
    p_detect: float | None = None,
    clutter_density: float | None = None,
    merge_extent: float | None = None,
    agent_kwargs: Mapping[str, Any] | None = None,
    max_iterations: int = 5,
) -> SensorModelEstimate:
    """Estimate the tracker's settings from the detections (module docstring).

    Args:
        detections: The stream.
        spec: Its sensor spec (``dt``, region, sizes; its ``noise_std`` is not used).
        predictor: The predictor the settings are for: one with a kinematic model
            (``Capability.KINEMATIC_MODEL``: ``kf-ca``, ``kf-cv``, ``random-walk``); any other:
            only the measurement noise applies, estimated with
            `FALLBACK_PREDICTOR`'s model.
        noise_std: A given measurement noise std (input units), kept instead of estimated.
        q: A given process noise intensity, kept instead of estimated.
        velocity_mean: A given velocity prior mean (input units per second), kept as given.
        velocity_std: A given velocity prior std (input units per second), kept as given.
        p_detect: A given detection probability in (0, 1], kept (and told to every tracking run);
            None: ``spec.p_detect`` where the spec declares one (below 1), else estimated.
        clutter_density: A given clutter density (detections per unit area, input units^D, and
            frame), >= 0, kept (and told to every tracking run); None: the spec's (its
            ``clutter_rate`` over its region) where it declares clutter, else estimated.
        merge_extent: A given jpda merge extent (input units), > 0, kept.
        agent_kwargs: Other gnn keywords of the tracking runs (e.g. ``p_gate``, ``max_misses``);
            a ``q``, ``initial_velocity`` or ``initial_velocity_std`` among them counts as given.
        max_iterations: Most tracking runs, >= 1.

    Returns:
        [`SensorModelEstimate`][agents.SensorModelEstimate].

    Raises:
        ValueError: a stream without two consecutive frames holding detections (nothing to
            estimate from), ``max_iterations < 1``, an unknown predictor name, or a given
            ``p_detect``, ``clutter_density`` or ``merge_extent`` out of its range.
    """
    if not (isinstance(max_iterations, int) and max_iterations >= 1):
        raise ValueError(f"max_iterations must be an integer >= 1, got {max_iterations!r}")
    if p_detect is None and 0.0 < spec.p_detect < 1.0:  # a spec that declares misses
        p_detect = float(spec.p_detect)
    if clutter_density is None and spec.clutter_rate > 0:  # a spec that declares clutter
        clutter_density = float(spec.clutter_rate) / float(np.prod(spec.region_size))
    _check_detection_model(p_detect, clutter_density, merge_extent)
    agent_kwargs = dict(agent_kwargs or {})
    given = _given_settings(noise_std, q, velocity_mean, velocity_std, agent_kwargs)
    given_misses = agent_kwargs.get("max_misses")
    scales = data_scales(detections)
    if scales is None:
        raise ValueError(
            "cannot estimate the sensor model: no two consecutive frames hold detections; give the "
            "measurement noise (--declared-noise-std) and the process noise (--process-noise) instead"
        )
    dt = spec.dt
    kinematic = tracking_model(predictor)[1]
    order = kinematic.order
    unit = _power_of_two(scales.length)
    normal, normal_spec = _normalised(detections, spec, agent_kwargs, unit)
    first = _with_given(first_settings(scales, dt, order), given)
    declared_density = float(spec.clutter_rate) / float(np.prod(spec.region_size))
    sensor = _SensorGiven(
        p_detect,
        clutter_density,
        float(spec.p_detect) if p_detect is None else p_detect,
        declared_density if clutter_density is None else clutter_density,
        int(given_misses) if given_misses is not None else MIN_MAX_MISSES,
    )
    runs = _iterate(
        detections,
        normal,
        normal_spec,
        predictor,
        first,
        given,
        agent_kwargs,
        unit,
        max_iterations,
        scales.length,
        sensor,
    )
    settings = runs.settings
    found = runs.detection
    p_hat = p_detect if p_detect is not None else (found.p_detect if found.p_detect is not None else 1.0)
    lam = clutter_density
    if lam is None:
        lam = found.clutter_density if found.clutter_density is not None else 0.0
    extent, rule = (
        (float(merge_extent), "given")
        if merge_extent is not None
        else estimate_merge_extent(detections, confident(runs.labels), scales.length)
    )
    p_gate = float(agent_kwargs.get("p_gate", DEFAULT_P_GATE))
    radii = coasting_radii(
        kinematic, dt, settings.q, settings.noise_std**2, p_gate, detections.dim, MAX_MAX_MISSES
    )
    gaps, reappearing = _reappearances(detections, runs.labels, dt, radii, scales.length)
    coast = int(gaps.max()) if len(gaps) and reappearing >= REAPPEAR_SHARE else MIN_MAX_MISSES
    max_misses = int(given_misses) if given_misses is not None else max(MIN_MAX_MISSES, coast)
    given |= {
        "max_misses": given_misses,
        "p_detect": p_detect,
        "clutter_density": clutter_density,
        "merge_extent": merge_extent,
    }
    sources = {k: ("given" if v is not None else "estimated") for k, v in given.items()}
    return SensorModelEstimate(
        dt=float(dt),
        predictor=predictor,
        model=MODEL_NAMES[order],
        noise_std=float(settings.noise_std),
        q=float(settings.q),
        velocity_mean=tuple(float(v) for v in settings.velocity_mean),
        velocity_std=float(settings.velocity_std),
        acceleration_std=float(settings.acceleration_std),
        p_gate=p_gate,
        gate_radius=float(radii[0]),
        length=float(scales.length),
        flow=tuple(float(v) for v in scales.flow),
        threshold=float(scales.length / 2),
        max_misses=max_misses,
        reappearing=float(reappearing),
        reappearance_gaps=tuple(int(g) for g in np.sort(gaps)),
        iterations=runs.runs,
        settled=runs.settled,
        n_tracks=runs.n_tracks,
        n_differences=0 if runs.noise is None else runs.noise.n_differences,
        p_detect=float(p_hat),
        n_gaps=found.n_gaps,
        clutter_density=float(lam),
        n_unclaimed=found.n_unclaimed,
        clutter_area=found.area,
        merge_extent=extent,
        merge_rule=rule,
        sources=sources,
        history=tuple(runs.history),
    )


def _given_settings(
    noise_std: float | None,
    q: float | None,
    velocity_mean: NDArray[np.floating] | None,
    velocity_std: float | None,
    agent_kwargs: dict[str, Any],
) -> dict[str, Any]:
    """The settings given (``None``: estimate it), by [`Settings`][agents.sensor_model.estimate.Settings]
    field; the ones given as gnn keywords are taken out of ``agent_kwargs`` (and ``velocity_fallback``
    dropped)."""
    given = {
        "noise_std": noise_std,
        "q": q if q is not None else agent_kwargs.pop("q", None),
        "velocity_mean": velocity_mean
        if velocity_mean is not None
        else agent_kwargs.pop("initial_velocity", None),
        "velocity_std": velocity_std
        if velocity_std is not None
        else agent_kwargs.pop("initial_velocity_std", None),
        "acceleration_std": agent_kwargs.pop("initial_acceleration_std", None),
    }
    agent_kwargs.pop("velocity_fallback", None)
    return given


def _with_given(s: Settings, given: Mapping[str, Any]) -> Settings:
    """``s`` with the given settings in place of its own."""
    return Settings(
        float(given["noise_std"]) if given["noise_std"] is not None else s.noise_std,
        float(given["q"]) if given["q"] is not None else s.q,
        np.asarray(given["velocity_mean"], np.float64)
        if given["velocity_mean"] is not None
        else s.velocity_mean,
        float(given["velocity_std"]) if given["velocity_std"] is not None else s.velocity_std,
        float(given["acceleration_std"]) if given["acceleration_std"] is not None else s.acceleration_std,
    )


def _normalised(
    detections: Detections, spec: SensorSpec, agent_kwargs: dict[str, Any], unit: float
) -> tuple[Detections, SensorSpec]:
    """The stream and spec in positions / ``unit`` (exact: a power of two), and the lengths among
    ``agent_kwargs`` (``region_margin``, ``blob_extent``) rescaled in place."""
    normal = Detections(
        detections.points / unit, detections.offsets, detections.ids, detections.first_frame, detections.times
    )
    normal_spec = dataclasses.replace(
        spec,
        region_low=tuple(v / unit for v in spec.region_low),
        region_high=tuple(v / unit for v in spec.region_high),
    )
    if "region_margin" in agent_kwargs:
        agent_kwargs["region_margin"] = float(agent_kwargs["region_margin"]) / unit
    if "blob_extent" in agent_kwargs:
        agent_kwargs["blob_extent"] = float(agent_kwargs["blob_extent"]) / unit
    return normal, normal_spec


def _check_detection_model(p_detect: Any, clutter_density: Any, merge_extent: Any) -> None:
    """Raise ``ValueError`` naming a given ``p_detect``, ``clutter_density`` or ``merge_extent``
    out of its range."""
    if p_detect is not None and not (
        isinstance(p_detect, int | float | np.floating) and 0.0 < p_detect <= 1.0
    ):
        raise ValueError(f"p_detect must be a probability in (0, 1], got {p_detect!r}")
    if clutter_density is not None and not (
        isinstance(clutter_density, int | float | np.floating)
        and math.isfinite(clutter_density)
        and clutter_density >= 0
    ):
        raise ValueError(f"clutter_density must be a finite number >= 0, got {clutter_density!r}")
    if merge_extent is not None and not (
        isinstance(merge_extent, int | float | np.floating)
        and math.isfinite(merge_extent)
        and merge_extent > 0
    ):
        raise ValueError(f"merge_extent must be a finite number > 0, got {merge_extent!r}")


@dataclass(frozen=True)
class _SensorGiven:
    """The detection model of the tracking runs: the given ``p_D`` and ``λ`` (None: estimated),
    those of the first run (the given or the spec's), and ``K``, the runs' ``max_misses``."""

    p_detect: float | None
    clutter_density: float | None
    first_p_detect: float
    first_clutter_density: float
    max_gap: int


@dataclass(frozen=True)
class _Runs:
    """What the tracking runs of [`_iterate`][agents.sensor_model.estimate._iterate] left: the last settings,
    the labels of the last run, the last noise estimate, and the figures of
    [`SensorModelEstimate`][agents.SensorModelEstimate]."""

    settings: Settings
    labels: NDArray[np.int64]
    noise: NoiseEstimate | None
    detection: DetectionModel
    n_tracks: int
    runs: int
    settled: bool
    history: list[tuple[float, float]]


def _iterate(
    detections: Detections,
    normal: Detections,
    normal_spec: SensorSpec,
    predictor: str,
    settings: Settings,
    given: Mapping[str, Any],
    agent_kwargs: Mapping[str, Any],
    unit: float,
    max_iterations: int,
    length: float,
    sensor: _SensorGiven,
) -> _Runs:
    """Steps 2–5 of the module docstring: track ``normal`` (``detections`` / ``unit``) with
    ``settings`` and the ``sensor``'s ``p_D`` and ``λ``, estimate new ones from the run's
    confident tracks (``length``: the stream's scale), until they settle or ``max_iterations``
    runs were made."""
    dt, order = normal_spec.dt, tracking_model(predictor)[1].order
    frames = detections.frame_index()
    p_detect, density = sensor.first_p_detect, sensor.first_clutter_density
    found_model: DetectionModel | None = None
    history: list[tuple[float, float]] = []
    settled = False
    noise: NoiseEstimate | None = None
    n_tracks = 0
    runs = 0
    labels = np.full(len(detections), -1, np.int64)
    for _ in range(max_iterations):
        run_spec = with_detection_model(normal_spec, p_detect, density * unit**detections.dim)
        tracks = _run_gnn(normal, run_spec, predictor, settings.scaled(1 / unit), agent_kwargs)
        runs += 1
        labels = detection_labels(normal, tracks)
        found_model = detection_model(
            detections.points, frames, detections.n_frames, labels, sensor.max_gap, MIN_TRACK_LENGTH
        )
        if sensor.p_detect is None and found_model.p_detect is not None:
            p_detect = found_model.p_detect
        if sensor.clutter_density is None and found_model.clutter_density is not None:
            density = found_model.clutter_density
        found = estimate_settings(detections, labels, dt, order, length, settings)
        if found is None:
            break
        new, noise = found
        new = _with_given(new, given)
        sure = confident(labels)
        n_tracks = count_distinct(sure[sure >= 0])
        history.append((new.noise_std, new.q))
        change = max(
            abs(math.log(new.noise_std / settings.noise_std)) if settings.noise_std > 0 else math.inf,
            abs(math.log(new.q / settings.q)) / 2,
        )
        settings = new
        if change < SETTLED:
            settled = True
            break
    assert found_model is not None  # max_iterations >= 1
    return _Runs(settings, labels, noise, found_model, n_tracks, runs, settled, history)


def _reappearances(
    detections: Detections, labels: NDArray[np.int64], dt: float, radii: NDArray[np.float64], length: float
) -> tuple[NDArray[np.int64], float]:
    """The gaps of the confident tracks' re-appearances
    ([`agents.sensor_model.coasting`][agents.sensor_model.coasting]) up to the ambiguity bound, and the share
    of track ends they are."""
    # the ambiguity bound: missed frames after which the gate still lies within length / 2
    horizon = int(np.sum(np.cumprod(radii[1:] <= length / 2)))
    gaps, n_ends = reappearance_gaps(
        detections.points, detections.frame_index(), confident(labels), dt, radii[: horizon + 1], START_SPAN
    )
    return gaps, (len(gaps) / n_ends if n_ends else 0.0)


def live_track_bound(detections: Detections, max_misses: int) -> int:
    """The most live tracks a GNN tracker can hold: a live track was updated or born in one of
    the last ``max_misses + 1`` frames, each with a detection of its own, so the most detections
    in any ``max_misses + 1`` consecutive frames (at least 1)."""
    if not detections.n_frames:
        return 1
    cum = np.concatenate([[0], np.cumsum(detections.counts)])
    w = min(max_misses + 1, detections.n_frames)
    return max(int((cum[w:] - cum[:-w]).max()), 1)
