"""Per-event scores of a tracker on the merge-event streams
([`track_envs.streams.merge_events`][track_envs.streams.merge_events]).

The agent runs over the whole stream once
([`agents.merge_scoring.run_on_stream`][agents.merge_scoring.run_on_stream], which fills a
[`TrackHistory`][track_envs.streams.merge_scoring.TrackHistory]); each event is then scored on the report in
its window, the ``W`` frames ``e + 1 … e + W`` after the event frame ``e``
([`score_events`][track_envs.streams.score_events]). Matching is by distance: a track *holds* particle ``p``
in frame ``t`` when it is the live track nearest to ``p`` and within ``match_radius`` of it (default 0.6 mm, a
third of the 1.8 mm lane gap, 20 σ of the sensor noise).

Joins and missed pairs: ``T_p``, the track holding ``p`` in frame ``e − 1``.

* **switches**: involved particles held in some window frame by a track other than ``T_p``;
  **swaps**: those held by the partner's ``T_q`` (the identities crossed);
* **lost**: involved particles held by no track in some window frame;
* **new tracks**: tracks first reported in frames ``e … e + W`` whose first position lies within
  ``birth_radius`` (3 mm) of an involved particle;
* **on neighbour**: ``T_p`` holds a particle that is not involved in some window frame;
* **max error**: ``max_t ‖ŷ_{T_p}(t) − x_p(t)‖`` over the window (∞ when ``T_p`` is gone);
* **kick**: the lateral velocity the track put into its state at the event, beyond its
  particle's own lateral motion: ``max_t |(ŷ⁻_y(t) − ŷ_y(t − 1)) − (x_y(t) − x_y(t − 1))|`` over
  ``t = e + 1 … e + W``, ``ŷ⁻(t)`` the track's predicted position for frame ``t`` and ``ŷ(t − 1)``
  its reported estimate of the frame before (in metres per frame). A filter that put the blob's
  jump into its velocity and acceleration predicts its track sideways past its particle's lane
  (on the belt recordings by 1–2 mm, where the lanes are 1.8 mm apart). Agents without the
  tracker-side prediction (the ``LAST_PREDICTION`` capability of [`agents.base`][agents.base]) give the
  reported steps ``ŷ_y(t) − ŷ_y(t − 1)`` instead, from
  ``t = e + 2`` on (a track that followed the blob at ``e`` rightly steps back into ``e + 1``),
  which see only what is left after each update.

The bounds a tracker that handles merged blobs should meet
([`bound_violations`][track_envs.streams.merge_scoring.bound_violations]), per scenario: at least
``RESOLVED_FRACTION`` (95 %) of the events resolved, and the 95th percentile of the kick at most
``KICK_BOUND`` (0.5 mm per frame). The particles move sideways by at most 0.05 mm per frame; 0.5 mm is six
times the kf-ca prediction spread of ≈0.08 mm (a squared Mahalanobis distance ≈37, past the 0.999 gate's
13.8), and under the 0.9 mm (half the 1.8 mm lane gap) beyond which the partner's detection lies nearer than
the particle's own.

An event is **resolved** when both particles are held by their own ``T_p`` in every window frame,
no new track starts, and the max error is within ``error_bound``.

Separations: ``T_0``, the track nearest the blob (the pair's midpoint) in frame ``e − 1``, within
``match_radius``. Resolved when ``T_0`` holds one piece in every window frame, exactly one new
track starts and holds the other piece in every window frame, and the max error of both (each
against its piece) is within ``error_bound``: neither track jumps sideways beyond its piece. The
kick and the switches are counted as above, with ``T_p`` the track that holds piece ``p`` in
frame ``e + 1``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from track_envs.infra.arguments import check_int, check_positive
from track_envs.streams.merge_events import MergeEventStream

MATCH_RADIUS = 6e-4  # m
BIRTH_RADIUS = 3e-3  # m
ERROR_BOUND = 3e-4  # m, 10 σ
RESOLVED_FRACTION = 0.95  # of the events of each scenario
KICK_BOUND = 5e-4  # m per frame, the kick's 95th percentile over the events of each scenario


@dataclass(frozen=True)
class TrackHistory:
    """The reports of one run: ids (T, R) int64 (−1 on empty rows) and positions (T, R, D); and,
    when the agent declares them (``LAST_PREDICTION``, [`agents.base`][agents.base]: the tracker-side
    channel of [`agents.gnn.agent.GnnAgent`][agents.gnn.agent.GnnAgent]), the predicted measurement of each
    track in each frame, ``predicted_ids`` (T, R) and ``predicted`` (T, R, D), else None."""

    ids: NDArray[np.int64]
    positions: NDArray[np.float64]
    predicted_ids: NDArray[np.int64] | None = None
    predicted: NDArray[np.float64] | None = None


@dataclass(frozen=True)
class EventScores:
    """Per-event scores (E,) of one run (module docstring); ``stream`` is the whole-stream
    CLEAR MOT / IDF1 ([`ClearMot`][track_envs.metrics.ClearMot] with merged ids, threshold
    `MATCH_RADIUS`), for reference only: on a separation
    stream it counts up to one switch per event even for a tracker that does everything right, as the blob's
    track matches the blob's first particle while merged and may then follow the other piece."""

    kind: str
    switches: NDArray[np.int64]
    swaps: NDArray[np.int64]
    lost: NDArray[np.int64]
    new_tracks: NDArray[np.int64]
    on_neighbour: NDArray[np.bool_]
    max_error: NDArray[np.float64]
    kick: NDArray[np.float64]
    resolved: NDArray[np.bool_]
    stream: dict[str, float]

    def summary(self) -> dict[str, float]:
        """Fractions of events and percentiles over events (errors and kicks in mm)."""
        return {
            "resolved": float(self.resolved.mean()),
            "with_switch": float((self.switches > 0).mean()),
            "with_swap": float((self.swaps > 0).mean()),
            "with_lost": float((self.lost > 0).mean()),
            "new_tracks_per_event": float(self.new_tracks.mean()),
            "on_neighbour": float(self.on_neighbour.mean()),
            "max_error_p50_mm": float(np.median(self.max_error) * 1e3),
            "max_error_p95_mm": float(np.quantile(self.max_error, 0.95, method="higher") * 1e3),
            "kick_p50_mm": float(np.median(self.kick) * 1e3),
            "kick_p95_mm": float(np.quantile(self.kick, 0.95, method="higher") * 1e3),
            "id_switches": self.stream["id_switches"],
            "idf1": self.stream["idf1"],
        }


def bound_violations(scores: EventScores) -> list[str]:
    """The bounds (module docstring) that ``scores`` breaks, one line each (empty: none)."""
    out = []
    resolved = float(scores.resolved.mean())
    if resolved < RESOLVED_FRACTION:
        out.append(
            f"{scores.kind}: {resolved:.0%} of {len(scores.resolved)} events resolved, "
            f"need >= {RESOLVED_FRACTION:.0%} ({scores.summary()})"
        )
    kick = float(np.quantile(scores.kick, 0.95, method="higher"))
    if not kick <= KICK_BOUND:
        out.append(f"{scores.kind}: lateral kick p95 {kick * 1e3:.3g} mm/frame, need <= {KICK_BOUND * 1e3:g}")
    return out


def concat_scores(scores: list[EventScores]) -> EventScores:
    """The events of several runs of one scenario as one [`EventScores`][track_envs.streams.EventScores]
    (``stream``: the runs' CLEAR MOT counts summed, IDF1 left out)."""
    if not scores or len({s.kind for s in scores}) != 1:
        raise ValueError(
            f"scores must be a non-empty list of one scenario, got kinds {[s.kind for s in scores]}"
        )
    fields = ("switches", "swaps", "lost", "new_tracks", "on_neighbour", "max_error", "kick", "resolved")
    return EventScores(
        kind=scores[0].kind,
        **{f: np.concatenate([getattr(s, f) for s in scores]) for f in fields},
        stream={"id_switches": float(sum(s.stream["id_switches"] for s in scores)), "idf1": np.nan},
    )


def _holders(
    history: TrackHistory, frames: NDArray[np.int64], x: NDArray[np.float64], radius: float
) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """The track holding each point ``x`` (F, P, D) in ``frames`` (F,): ids (F, P), −1 for none,
    and the distance to the nearest track (F, P)."""
    y = history.positions[frames]  # (F, R, D)
    d = np.linalg.norm(y[:, None] - x[:, :, None], axis=-1)  # (F, P, R)
    d = np.where(np.isnan(d), np.inf, d)
    nearest = d.argmin(axis=2)
    dist = np.take_along_axis(d, nearest[..., None], 2)[..., 0]
    held = np.take_along_axis(history.ids[frames], nearest, 1)
    return np.where(dist <= radius, held, -1), dist


def _track_positions(history: TrackHistory, frames: NDArray[np.int64], track: int) -> NDArray[np.float64]:
    """(F, D) positions of ``track`` in ``frames`` (NaN where it is not reported)."""
    rows = history.ids[frames] == track
    out = np.full((len(frames), history.positions.shape[2]), np.nan)
    f, r = np.nonzero(rows)
    out[f] = history.positions[frames[f], r]
    return out


def score_events(
    stream: MergeEventStream,
    history: TrackHistory,
    mot: dict[str, float] | None = None,
    *,
    window: int = 20,
    match_radius: float = MATCH_RADIUS,
    birth_radius: float = BIRTH_RADIUS,
    error_bound: float = ERROR_BOUND,
) -> EventScores:
    """Score every event of ``stream`` on ``history`` (see the module docstring)."""
    window = check_int("window", window, 2)
    match_radius = check_positive("match_radius", match_radius)
    birth_radius = check_positive("birth_radius", birth_radius)
    error_bound = check_positive("error_bound", error_bound)
    if int(stream.event_frames.max()) + window >= len(stream):
        raise ValueError(f"window={window} runs past the stream's last frame {len(stream) - 1}")
    first_seen = _first_seen(history)
    e_count = len(stream.event_frames)
    cols = {k: np.zeros(e_count, np.int64) for k in ("switches", "swaps", "lost", "new")}
    on_neighbour = np.zeros(e_count, bool)
    max_error = np.zeros(e_count)
    kick = np.zeros(e_count)
    resolved = np.zeros(e_count, bool)
    for k, (e, pair) in enumerate(zip(stream.event_frames, stream.involved, strict=True)):
        after = np.arange(e + 1, e + window + 1)
        x = stream.positions[after][:, pair]  # (W, 2, D)
        held, _ = _holders(history, after, x, match_radius)
        before = stream.positions[e - 1 : e][:, pair]
        if stream.kind == "separation":
            origin, _ = _holders(history, np.array([e - 1]), before.mean(axis=1, keepdims=True), match_radius)
            own = held[0].copy()  # each piece's track: the one holding it first
        else:
            origin, _ = _holders(history, np.array([e - 1]), before, match_radius)
            own = origin[0].copy()
        births = _births(history, first_seen, e, e + window, stream.positions, pair, birth_radius)
        cols["new"][k] = len(births)
        keeps = (held == own[None]).all(axis=0) & (own >= 0)
        cols["switches"][k] = int((((held != own[None]) & (held >= 0)).any(axis=0)).sum())
        cols["swaps"][k] = int(sum((held[:, i] == own[1 - i]).any() and own[1 - i] >= 0 for i in range(2)))
        cols["lost"][k] = int((held < 0).any(axis=0).sum())
        errors, kicks = np.zeros(2), np.zeros(2)
        others = np.setdiff1d(np.flatnonzero(stream.visible[e]), pair)
        for i in range(2):
            y = (
                _track_positions(history, after, int(own[i]))
                if own[i] >= 0
                else np.full(x[:, i].shape, np.nan)
            )
            err = np.linalg.norm(y - x[:, i], axis=1)
            errors[i] = np.inf if np.isnan(err).any() else err.max()
            kicks[i] = _kick(history, stream, e, window, int(own[i]), int(pair[i]), y)
            if own[i] >= 0:
                near, _ = _holders(history, after, stream.positions[after][:, others], match_radius)
                on_neighbour[k] |= bool((near == own[i]).any())
        max_error[k], kick[k] = errors.max(), kicks.max()
        if stream.kind == "separation":
            t0 = int(origin[0, 0])
            ok = t0 >= 0 and t0 in own and len(births) == 1 and int(births[0]) in own
        else:
            ok = bool((own >= 0).all()) and own[0] != own[1] and len(births) == 0
        resolved[k] = bool(ok and keeps.all() and max_error[k] <= error_bound)
    return EventScores(
        kind=stream.kind,
        switches=cols["switches"],
        swaps=cols["swaps"],
        lost=cols["lost"],
        new_tracks=cols["new"],
        on_neighbour=on_neighbour,
        max_error=max_error,
        kick=kick,
        resolved=resolved,
        stream=mot if mot is not None else {"id_switches": np.nan, "idf1": np.nan},
    )


def _kick(
    history: TrackHistory,
    stream: MergeEventStream,
    e: int,
    window: int,
    track: int,
    particle: int,
    y: NDArray[np.float64],
) -> float:
    """The largest lateral step the track's state carries beyond its particle's in the window
    (module docstring): with predictions, ``|(ŷ⁻_y(t) − ŷ_y(t − 1)) − (x_y(t) − x_y(t − 1))|`` for
    ``t = e + 1 … e + W`` (``ŷ⁻``: the prediction for frame ``t``, ``ŷ``: the reported estimate);
    without, the reported steps from ``e + 2`` on. NaN frames are skipped; ∞ when none is left."""
    if track < 0:
        return np.inf
    lateral = stream.positions[e : e + window + 1, particle, 1]
    truth_step = np.diff(lateral)  # into e + 1 … e + W
    if history.predicted is not None and history.predicted_ids is not None:
        frames = np.arange(e + 1, e + window + 1)
        predicted = _track_positions(TrackHistory(history.predicted_ids, history.predicted), frames, track)[
            :, 1
        ]
        estimate = _track_positions(history, frames - 1, track)[:, 1]
        step = predicted - estimate - truth_step
    else:
        step = np.diff(y[:, 1]) - truth_step[1:]
    return float(np.inf) if np.isnan(step).all() else float(np.nanmax(np.abs(step)))


def _first_seen(history: TrackHistory) -> dict[int, tuple[int, NDArray[np.float64]]]:
    """Every track id → the frame it was first reported in and its position there."""
    f, r = np.nonzero(history.ids >= 0)
    ids = history.ids[f, r]
    _, first = np.unique(ids, return_index=True)
    return {int(ids[i]): (int(f[i]), history.positions[f[i], r[i]]) for i in first}


def _births(
    history: TrackHistory,
    first_seen: dict[int, tuple[int, NDArray[np.float64]]],
    start: int,
    stop: int,
    positions: NDArray[np.float64],
    pair: NDArray[np.int64],
    radius: float,
) -> NDArray[np.int64]:
    """Tracks first reported in frames ``start … stop`` within ``radius`` of a particle of ``pair``."""
    out = [
        track
        for track, (t, y) in first_seen.items()
        if start <= t <= stop and np.linalg.norm(positions[t, pair] - y, axis=1).min() <= radius
    ]
    return np.asarray(sorted(out), np.int64)
