"""Gating clusters: tracks and detections linked, directly or through others, by a gate.

The gate matrix ``G`` (n_tracks, n_detections) is the biadjacency matrix of a bipartite graph
with a vertex per track and per detection and an edge for every admissible pair. JPDA's joint
events factorise over the connected components of that graph (no event couples two components),
so the marginal association probabilities of each component can be computed on its own
(Fortmann, Bar-Shalom, Scheffe: Sonar tracking of multiple targets using joint probabilistic data
association, 1983, the "validation matrix" split into clusters).

The components come from one call to ``scipy.sparse.csgraph.connected_components`` on the
``(n + m) × (n + m)`` adjacency ``[[0, G], [Gᵀ, 0]]``. A track without admissible detections and
a detection inside no gate are components of their own.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

IntArray = NDArray[np.intp]


@dataclass(frozen=True)
class GateClusters:
    """Connected components of the track–detection gate graph.

    Attributes:
        track_cluster: (n_tracks,) component label of each track, in ``0 .. n_clusters - 1``.
        detection_cluster: (n_detections,) component label of each detection.
        n_clusters: number of components (labels are consecutive).
    """

    track_cluster: IntArray
    detection_cluster: IntArray
    n_clusters: int

    def n_tracks(self) -> IntArray:
        """(n_clusters,) number of tracks in each component."""
        return np.bincount(self.track_cluster, minlength=self.n_clusters)

    def n_detections(self) -> IntArray:
        """(n_clusters,) number of detections in each component."""
        return np.bincount(self.detection_cluster, minlength=self.n_clusters)

    def members(self) -> list[tuple[IntArray, IntArray]]:
        """``(tracks, detections)`` index arrays of every component, ascending, by label.

        One stable sort per side, then a split at the label boundaries.
        """
        return list(
            zip(
                _split_by_label(self.track_cluster, self.n_clusters),
                _split_by_label(self.detection_cluster, self.n_clusters),
                strict=True,
            )
        )


def _split_by_label(labels: IntArray, n_labels: int) -> list[IntArray]:
    if n_labels == 0:
        return []
    order = np.argsort(labels, kind="stable")
    bounds = np.cumsum(np.bincount(labels, minlength=n_labels))[:-1]
    return [part.astype(np.intp) for part in np.split(order, bounds)]


def gate_clusters(gate: NDArray[np.bool_]) -> GateClusters:
    """Connected components of the bipartite graph with biadjacency ``gate``.

    Args:
        gate: (n_tracks, n_detections) boolean; ``gate[i, j]`` when detection ``j`` is inside the
            gate of track ``i``.

    Raises:
        ValueError: if ``gate`` is not two-dimensional or not boolean.
    """
    g = np.asarray(gate)
    if g.ndim != 2:
        raise ValueError(f"gate must be a (n_tracks, n_detections) matrix, got shape {g.shape}")
    if g.dtype != np.bool_:
        raise ValueError(f"gate must be boolean, got dtype {g.dtype}")
    n, m = g.shape
    rows, cols = np.nonzero(g)
    graph = coo_matrix((np.ones(len(rows), dtype=np.int8), (rows, n + cols)), shape=(n + m, n + m))
    n_clusters, labels = connected_components(graph, directed=False)
    labels = labels.astype(np.intp)
    return GateClusters(labels[:n], labels[n:], int(n_clusters))
