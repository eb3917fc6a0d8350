"""Association errors of the first and second kind (e1, e2, e_mean) for bulk-material tracking.

Pfaff, Kurz, Pieper et al., "Improving Multitarget Tracking Using Orientation Estimates for
Sorting Bulk Materials", MFI 2017 (reference [15] of Pollithy, Reith-Braun, Pfaff, Hanebeck,
"Estimating Uncertainties of Recurrent Neural Networks in Application to Multitarget Tracking",
MFI 2020, Sec. V-C). Ideally all measurements of one particle go to one
track and only they do. Over an episode collect, for every track, the set of particles whose
measurements it was updated with (clutter ignored) and, for every particle, the set of tracks its
measurements went to. Then

.. math::

    \\hat e_1 = \\frac{\\#\\{\\text{tracks holding measurements of} > 1 \\text{ particle}\\}}
        {n_\\text{tracks}},
    \\qquad
    \\hat e_2 = \\frac{\\#\\{\\text{particles whose measurements went to} \\ne 1 \\text{ track}\\}}
        {n_\\text{particles}},

    e_\\text{mean} = \\frac{2 \\hat e_1 \\hat e_2}{\\hat e_1 + \\hat e_2}
        \\quad (0 \\text{ when both are } 0),

where ``n_tracks`` counts the tracks that were updated with at least one real (non-clutter)
measurement and ``n_particles`` the particles that produced at least one detection; a particle
whose measurements were never associated counts as an error of the second kind.

**Merged detections** (touching particles seen as one blob, ``detection_ids`` given as
(max_detections, K) merged ids): an update of a track with a merged detection is correct for
whichever of its particles the track follows — it adds no pair when the track holds a
single-particle measurement of one of them, and otherwise counts as a measurement of the
detection's primary particle; every particle behind a detection counts as detected (see
[`track_envs.metrics.merged`][track_envs.metrics.merged]).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import NDArray

from track_envs.infra.compiled import njit
from track_envs.metrics.base import MetricTraits, report_mask
from track_envs.metrics.key_table import KeyTable, add_entry
from track_envs.metrics.merged import as_merged, resolve_merged, set_key


@njit(cache=True)
def _add_frame(
    sources: NDArray[np.int64],
    track_ids: NDArray[np.int64],
    rows: NDArray[np.int64],
    mask: NDArray[np.int8],
    particle_index: NDArray[np.int64],
    particle_entries: NDArray[np.int64],
    pair_index: NDArray[np.int64],
    pair_entries: NDArray[np.int64],
) -> None:
    """Add the frame's particles and (track id, particle id) pairs to the two key sets."""
    n_sources = len(sources)
    for s in sources:
        if s >= 0:
            add_entry(particle_index, particle_entries, s, 0)
    for k in range(len(mask)):
        r = rows[k]
        if mask[k] == 1 and 0 <= r < n_sources and sources[r] >= 0:
            add_entry(pair_index, pair_entries, track_ids[k], sources[r])


@njit(cache=True)
def _add_merged_frame(
    sources: NDArray[np.int64],
    track_ids: NDArray[np.int64],
    rows: NDArray[np.int64],
    mask: NDArray[np.int8],
    particle_index: NDArray[np.int64],
    particle_entries: NDArray[np.int64],
    pair_index: NDArray[np.int64],
    pair_entries: NDArray[np.int64],
    record_index: NDArray[np.int64],
    record_entries: NDArray[np.int64],
) -> None:
    """As [`_add_frame`][track_envs.metrics.belt._add_frame] with merged ids (max_detections, K); merged
    updates become records ``(track id, set key, members...)`` (the tables must have room for ``len(mask)``
    more)."""
    n_sources, k_cols = sources.shape
    for r in range(n_sources):
        for k in range(k_cols):
            if sources[r, k] >= 0:
                add_entry(particle_index, particle_entries, sources[r, k], 0)
    for t in range(len(mask)):
        r = rows[t]
        if mask[t] != 1 or not (0 <= r < n_sources) or sources[r, 0] < 0:
            continue
        if k_cols < 2 or sources[r, 1] < 0:
            add_entry(pair_index, pair_entries, track_ids[t], sources[r, 0])
        else:
            e = add_entry(record_index, record_entries, track_ids[t], set_key(sources[r]))
            record_entries[e, 2:] = sources[r]


class AssociationErrors:
    """Streaming e1 / e2 / e_mean of an episode (Pfaff et al. 2017; Pollithy et al. 2020, Sec. V-C).

    Each frame contributes the (track id, particle id) pairs of the report rows (mask 1) whose
    ``detection`` row holds a real measurement (``detection_ids[row] >= 0``); coasting rows
    (−1), rows pointing outside the detections and clutter rows are ignored. Pairs and particles
    are kept as hash sets (`KeyTable`) updated by a compiled
    kernel per frame, so memory grows with the number of distinct pairs, not frames.

    Track ids in a frame are unique and non-negative by the report contract
    ([`track_envs.contracts.report.validate_report`][track_envs.contracts.validate_report]); a track is its
    id, so a track id reused in a later frame for another particle counts as one track holding two particles.
    (Fed a report that breaks the contract directly, rows sharing an id are merged into one track.)

    With no qualifying tracks ``e1`` is 0 (no track is in error), with no particles ``e2`` is 0.

    Merged detections (``detection_ids`` (max_detections, K), as ``info["detection_ids_merged"]``)
    count an association to either particle's track as correct (module docstring); updates with
    them are kept as records keyed by (track id, set of particles) and resolved in
    [`compute`][track_envs.metrics.AssociationErrors.compute].
    """

    traits = MetricTraits(needs_truth=True, accepts_merged_ids=True)

    def __init__(self) -> None:
        self.reset()

    def reset(self) -> None:
        """Forget every frame (start a new episode)."""
        self._pairs = KeyTable(n_values=0)  # (track id, particle id)
        self._particles = KeyTable(n_values=0)  # (particle id, 0)
        self._records: KeyTable | None = None  # (track id, set key) -> members, for merged updates

    def update(
        self, truth: Mapping[str, NDArray], detection_ids: NDArray[np.int64], report: Mapping[str, NDArray]
    ) -> None:
        """Add one frame.

        Args:
            truth: ``info["truth"]`` of the frame (unused: the particles are known from
                ``detection_ids``; kept for the [`Metric`][track_envs.metrics.Metric] interface).
            detection_ids: (max_detections,) truth id behind each detection row, −1 for clutter
                and padding; or (max_detections, K) every truth id behind each row, −1 padded,
                column 0 the primary (``info["detection_ids_merged"]``).
            report: The report answering the frame.

        Raises:
            ValueError: if ``detection_ids`` is not 1-D or 2-D, or its K changes in an episode.
        """
        del truth
        if np.ndim(detection_ids) != 1:
            self._update_merged(as_merged(detection_ids), report)
            return
        sources = np.ascontiguousarray(detection_ids, dtype=np.int64).reshape(-1)
        track_ids = np.ascontiguousarray(report["ids"], dtype=np.int64)
        rows = np.ascontiguousarray(report["detection"], dtype=np.int64)
        mask = report_mask(report)
        self._particles.reserve(len(sources))
        self._pairs.reserve(len(mask))
        _add_frame(
            sources,
            track_ids,
            rows,
            mask,
            self._particles.index,
            self._particles.entries,
            self._pairs.index,
            self._pairs.entries,
        )

    def _update_merged(self, sources: NDArray[np.int64], report: Mapping[str, NDArray]) -> None:
        k_cols = sources.shape[1]
        if self._records is None:
            self._records = KeyTable(n_values=k_cols)
        elif self._records.entries.shape[1] != 2 + k_cols:
            raise ValueError(
                f"detection_ids has {k_cols} columns, but {self._records.entries.shape[1] - 2} earlier "
                "in this episode; reset() between streams of different widths"
            )
        track_ids = np.ascontiguousarray(report["ids"], dtype=np.int64)
        rows = np.ascontiguousarray(report["detection"], dtype=np.int64)
        mask = report_mask(report)
        self._particles.reserve(sources.size)
        self._pairs.reserve(len(mask))
        self._records.reserve(len(mask))
        records = self._records
        _add_merged_frame(
            sources,
            track_ids,
            rows,
            mask,
            self._particles.index,
            self._particles.entries,
            self._pairs.index,
            self._pairs.entries,
            records.index,
            records.entries,
        )

    def _all_pairs(self) -> NDArray[np.int64]:
        """The (track id, particle id) pairs of every update, merged ones resolved."""
        pairs = self._pairs.stored_keys()
        if self._records is None or not len(self._records):
            return pairs
        extra = resolve_merged(
            self._pairs.index,
            self._pairs.entries,
            np.ascontiguousarray(self._records.entries[: len(self._records)]),
        )
        return np.unique(np.concatenate([pairs, extra]), axis=0)

    def compute(self) -> dict[str, float]:
        """``{"e1", "e2", "e_mean", "n_tracks", "n_particles"}`` over every frame added."""
        pairs = self._all_pairs()
        particles = np.sort(self._particles.stored_keys()[:, 0])
        _, per_track = np.unique(pairs[:, 0], return_counts=True)
        n_tracks = len(per_track)
        e1 = float(np.count_nonzero(per_track > 1)) / n_tracks if n_tracks else 0.0
        assoc_ids, per_particle = np.unique(pairs[:, 1], return_counts=True)
        tracks_of = np.zeros(len(particles), dtype=np.int64)
        tracks_of[np.searchsorted(particles, assoc_ids)] = per_particle
        n_particles = len(particles)
        e2 = float(np.count_nonzero(tracks_of != 1)) / n_particles if n_particles else 0.0
        e_mean = 2 * e1 * e2 / (e1 + e2) if e1 + e2 > 0 else 0.0
        return {
            "e1": e1,
            "e2": e2,
            "e_mean": e_mean,
            "n_tracks": float(n_tracks),
            "n_particles": float(n_particles),
        }
