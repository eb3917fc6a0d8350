"""Merged detections in the metrics: one detection that stands for several particles.

A camera reports touching particles as one blob at their area-weighted centroid
([`track_envs.envs.blobs`][track_envs.envs.blobs]); the env then lists every truth id behind each detection
row in ``info["detection_ids_merged"]`` (max_detections, K), −1 padded, column 0 being
``info["detection_ids"]``. A tracker that updates a track with such a detection has done nothing
wrong whichever of the particles the track follows, so the metrics count the association of a
merged detection to *either* particle's track as correct:

* **e1 / e2** ([`AssociationErrors`][track_envs.metrics.AssociationErrors]): an update of track ``T``
  with a merged detection of particles ``S`` adds no pair when ``T`` holds a measurement of some
  ``s ∈ S`` from a detection of one particle (at any time of the episode); otherwise (a track only
  ever fed by merged detections) it counts as a measurement of the detection's primary particle
  (its largest, ``S[0]``). Every member of ``S`` counts as a particle that produced a detection.
* **CLEAR MOT / IDF1** ([`ClearMot`][track_envs.metrics.ClearMot]): a track updated with a
  merged detection may match any member ``o ∈ S`` within ``threshold + max_{o' ∈ S} |x_o − x_o'|``
  instead of ``threshold``: the blob's centroid lies in the convex hull of the members' centres,
  so a track within ``threshold`` of the centroid is within that distance of each member (the
  triangle inequality). The match distance entering MOTP is the true one.

Metrics that read merged ids say so with ``traits = MetricTraits(accepts_merged_ids=True)``;
[`TrackingMetrics`][track_envs.wrappers.TrackingMetrics] hands them ``info["detection_ids_merged"]`` when the
env provides it, and ``info["detection_ids"]`` (one id per row) to every other metric.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from track_envs.infra.compiled import njit
from track_envs.metrics.key_table import find_entry, hash_slot


def as_merged(detection_ids: NDArray[np.integer]) -> NDArray[np.int64]:
    """``detection_ids`` as a C-contiguous (max_detections, K) int64 array (K = 1 for plain ids)."""
    ids = np.asarray(detection_ids)
    if ids.ndim == 1:
        ids = ids[:, None]
    if ids.ndim != 2:
        raise ValueError(
            f"detection_ids must be (max_detections,) or (max_detections, K) truth ids, got shape {ids.shape}"
        )
    return np.ascontiguousarray(ids, dtype=np.int64)


@njit(cache=True)
def set_key(members: NDArray[np.int64]) -> int:
    """A 64-bit key of the set of ids ``members[members >= 0]`` (independent of their order)."""
    n = 0
    for v in members:
        n += v >= 0
    ids = np.empty(n, np.int64)
    k = 0
    for v in members:
        if v >= 0:
            ids[k] = v
            k += 1
    ids.sort()
    h = n
    for v in ids:
        h = hash_slot(h, int(v), -1)
    return h


@njit(cache=True)
def resolve_merged(
    pair_index: NDArray[np.int64], pair_entries: NDArray[np.int64], records: NDArray[np.int64]
) -> NDArray[np.int64]:
    """The (track id, particle id) pairs the merged records add (see the module docstring).

    Args:
        pair_index, pair_entries: The [`KeyTable`][track_envs.metrics.key_table.KeyTable] of the pairs
            from single-particle detections.
        records: (r, 2 + K) keys ``(track id, set key)`` and the members of each merged update.
    """
    out = np.empty((len(records), 2), np.int64)
    n = 0
    for r in range(len(records)):
        track = records[r, 0]
        held = False
        for k in range(2, records.shape[1]):
            s = records[r, k]
            if s >= 0 and find_entry(pair_index, pair_entries, track, s) >= 0:
                held = True
                break
        if not held:
            out[n, 0] = track
            out[n, 1] = records[r, 2]
            n += 1
    return out[:n]


@njit(cache=True)
def with_merged_pairs(
    x: NDArray[np.float64],
    oids: NDArray[np.int64],
    y: NDArray[np.float64],
    rows: NDArray[np.int64],
    merged: NDArray[np.int64],
    threshold: float,
    ptr: NDArray[np.int64],
    cols: NDArray[np.int64],
    dist: NDArray[np.float64],
) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.float64]]:
    """The possible truth–track pairs ``(ptr, cols, dist)`` with the pairs of merged updates added.

    Args:
        x, oids: Live truth positions (m, D) and ids (m,).
        y, rows: Live report positions (n, D) and the detection row each was updated with (n,).
        merged: (max_detections, K) truth ids behind each detection row.
        threshold: The match threshold.
        ptr, cols, dist: The pairs within ``threshold`` (row-major, ascending columns).

    Returns:
        The same form, with every pair of a track ``j`` updated with a merged detection and a
            member ``o`` of it at distance ``<= threshold + spread(o)`` (module docstring).
    """
    m, n = x.shape[0], y.shape[0]
    n_dims = x.shape[1]
    n_det, k_cols = merged.shape
    n_merged = 0
    for j in range(n):
        r = rows[j]
        n_merged += 0 <= r < n_det and k_cols >= 2 and merged[r, 1] >= 0
    if n_merged == 0:
        return ptr, cols, dist
    # truth row of each id: an open-addressing index of the frame's truth ids (first row wins)
    n_slots = 2
    while n_slots < 2 * m:
        n_slots *= 2
    slot_mask = n_slots - 1
    row_of = np.full(n_slots, -1, np.int64)
    for i in range(m):
        s = hash_slot(oids[i], 0, slot_mask)
        while row_of[s] >= 0 and oids[row_of[s]] != oids[i]:
            s = (s + 1) & slot_mask
        if row_of[s] < 0:
            row_of[s] = i
    extra_i = np.empty(n_merged * k_cols, np.int64)
    extra_j = np.empty(n_merged * k_cols, np.int64)
    extra_d = np.empty(n_merged * k_cols, np.float64)
    member = np.empty(k_cols, np.int64)
    n_extra = 0
    for j in range(n):
        r = rows[j]
        if r < 0 or r >= n_det or k_cols < 2 or merged[r, 1] < 0:
            continue
        count = 0
        for k in range(k_cols):  # the members' truth rows
            o = merged[r, k]
            if o < 0:
                continue
            s = hash_slot(o, 0, slot_mask)
            while row_of[s] >= 0 and oids[row_of[s]] != o:
                s = (s + 1) & slot_mask
            if row_of[s] >= 0:
                member[count] = row_of[s]
                count += 1
        for a in range(count):
            i = member[a]
            spread = 0.0
            for b in range(count):
                sq = 0.0
                for d in range(n_dims):
                    step = x[i, d] - x[member[b], d]
                    sq += step * step
                spread = max(spread, np.sqrt(sq))
            sq = 0.0
            for d in range(n_dims):
                step = x[i, d] - y[j, d]
                sq += step * step
            dij = np.sqrt(sq)
            if threshold < dij <= threshold + spread:
                extra_i[n_extra] = i
                extra_j[n_extra] = j
                extra_d[n_extra] = dij
                n_extra += 1
    if n_extra == 0:
        return ptr, cols, dist
    per_row = np.zeros(m + 1, np.int64)
    for e in range(n_extra):
        per_row[extra_i[e] + 1] += 1
    new_ptr = ptr.copy()
    shift = 0
    for i in range(m):
        shift += per_row[i + 1]
        new_ptr[i + 1] += shift
    new_cols = np.empty(len(cols) + n_extra, np.int64)
    new_dist = np.empty(len(cols) + n_extra, np.float64)
    for i in range(m):
        at = new_ptr[i]
        for t in range(ptr[i], ptr[i + 1]):
            new_cols[at] = cols[t]
            new_dist[at] = dist[t]
            at += 1
        for e in range(n_extra):
            if extra_i[e] == i:
                new_cols[at] = extra_j[e]
                new_dist[at] = extra_d[e]
                at += 1
        # ascending columns within the row (a row holds a handful of pairs)
        for a in range(new_ptr[i] + 1, at):
            j, dd = new_cols[a], new_dist[a]
            b = a
            while b > new_ptr[i] and new_cols[b - 1] > j:
                new_cols[b] = new_cols[b - 1]
                new_dist[b] = new_dist[b - 1]
                b -= 1
            new_cols[b] = j
            new_dist[b] = dd
    return new_ptr, new_cols, new_dist
