r"""Joint probabilistic data association (JPDA) tracker, with touching particles as merged blobs.

Every frame, for the ``n`` live tracks and the ``m`` detections:

1. **predict** as gnn: ``N(ŷ_i, S_i)`` from the predictor;
2. **associate probabilistically** (Fortmann, Bar-Shalom and Scheffe: Sonar tracking of multiple
   targets using joint probabilistic data association, 1983): every joint event — each track
   missed, taking one detection of its gate, or, with the merge model, taking together with a
   neighbour one detection as their *merged blob* — is weighed by its likelihood against Poisson
   clutter of density ``λ`` and the detection probability ``p_D``; the marginal probabilities of
   the events are exact per gating cluster ([`agents.jpda._kernels`][agents.jpda._kernels], one compiled pass;
   clusters of more than ``max_exact`` tracks fall back to loopy belief propagation without merged
   blobs, [`agents.jpda.lbp`][agents.jpda.lbp], and their tracks are counted in
   [`JpdaAgent.approximate_tracks`][agents.jpda.agent.JpdaAgent.approximate_tracks] — with the coalescence
   guard (step 3) such tracks take gnn's assignment instead);
3. **update** every track by the moment-matched mixture of its hypotheses (the PDA update):
   exactly for predictors that declare ``MIXTURE_UPDATE`` (the Kalman filters,
   [`predictors.kalman.predictor.KalmanPredictor.update_mixture`][predictors.kalman.predictor.KalmanPredictor.update_mixture]);
   any other Gaussian predictor (the belt LSTMs) is updated through the core ``update`` by the mixture's mean
   ``ŷ + p (z̄ − ŷ)`` when the track was more likely detected than not (``p ≥ ½``) and coasts
   otherwise — for a predictor that reports its input, the moment-matched position. Two kinds
   of track take the frame's optimal assignment (gnn's gated Hungarian) instead: tracks not yet
   settled (fewer than 3 updates in a row: their gates span the neighbours), and, with the
   *coalescence guard* (default), tracks that share their gating cluster with other tracks and
   whose most probable hypothesis is not a merged blob — the mixtures of competing tracks pull
   them onto each other (JPDA's coalescence; Blom and Bloem 2000 prune the joint events
   instead). On the belt ≈99 % of the tracks are alone in their cluster;
4. **bookkeeping as gnn** (the same [`PointTracker`][agents.PointTracker] core, composed
   with [`JpdaAssociator`][agents.jpda.associator.JpdaAssociator]): a track counts as seen when ``p ≥ ½``
   and reports the detection of its most probable hypothesis; the capped second chance for tracks
   and detections left over ([`agents.tracking.second_chance`][agents.tracking.second_chance]), deletions
   after ``max_misses`` misses or on leaving the region, births from the detections no track claims,
   the learnt velocity prior and the nozzle-bar roll-out are the core's, as for gnn.

**Merged blobs.** Touching particles reach the camera as one detection at their area-weighted
centroid ([`track_envs.envs.blobs`][track_envs.envs.blobs]). A plain GNN gives that detection to one of the
two tracks, whose filter takes the jump of ≈ half the pair's distance as real motion, or starves the other.
Here a pair of tracks predicted within ``merge_extent`` may jointly take one detection near their
midpoint (covariance in [`agents.jpda._kernels`][agents.jpda._kernels]); each is then updated as a member of a
*rigid pair*, keeping the offset from the pair's centre that their last estimates had, so a join
is explained by both tracks and on separation each piece is closest to its own track's prediction.
While the blob lasts the pair's relative motion is not observed: keeping the members' *predicted*
offset instead (``rigid_merge=False``, the model before) extrapolates it unobserved, and a
constant-acceleration filter's relative acceleration (its estimation noise alone, ≈20 µm per
frame² at 200 Hz and 30 µm noise) grows the offset quadratically until the tracks cross and swap
particles when the blob falls apart (docs/association.md, *The merge model's identity swaps*). The
env's merge truth (``info``) is never read.

**Sensor model.** ``p_D`` and ``λ`` come from the sensor spec: ``p_detect`` and
``clutter_rate / area of the observed region``. A sensor that declares no clutter still gets the
floor ``min_clutter_rate`` (detections per frame), so a stray detection is never forced onto a
track; the gate probability ``P_G`` is gnn's ``p_gate``.
"""

from __future__ import annotations

import operator
from typing import Any

from agents.jpda.associator import (
    MERGE_AREA_STD,
    MERGE_EXTENT,
    MERGE_STREAK,
    MIN_CLUTTER_RATE,
    SETTLED_STREAK,
    JpdaAssociator,
)
from agents.jpda.marginals import MAX_EXACT
from agents.tracking.tracker import PointTracker
from predictors.base import Predictor

__all__ = [
    "MERGE_AREA_STD",
    "MERGE_EXTENT",
    "MERGE_STREAK",
    "MIN_CLUTTER_RATE",
    "SETTLED_STREAK",
    "JpdaAgent",
]


class _FromAssociator:
    """A read-only attribute of the tracker: its associator's attribute of the same name."""

    def __set_name__(self, owner: type, name: str) -> None:
        self._get = operator.attrgetter(name)

    def __get__(self, tracker: Any, owner: type | None = None) -> Any:
        return self if tracker is None else self._get(tracker.associator)


class JpdaAgent(PointTracker):
    """JPDA multi-target tracker with merged-blob events and the PDA update (module docstring).

    A [`PointTracker`][agents.PointTracker] built with
    [`JpdaAssociator`][agents.jpda.associator.JpdaAssociator]; it adds no behaviour of its own, and shows
    the associator's settings and figures (``p_detect``, ``clutter_density``, ``merge_model``, ...,
    ``approximate_tracks``, ``blob_splits``, ``last_cluster_tracks``, ``last_p_seen``) as its
    attributes.

    Args:
        predictor: A Gaussian predictor's registered name or object, as for gnn.
        p_detect: ``p_D`` in (0, 1]; None: the sensor spec's ``p_detect`` (at least 0.01).
        clutter_density: ``λ``, clutter detections per unit area (volume) of measurement space,
            > 0; None: ``max(clutter_rate, min_clutter_rate)`` over the region's area.
        min_clutter_rate: Floor of the spec's clutter rate (detections per frame), > 0.
        merge_model: Whether two tracks may take one detection as their merged blob.
        merge_extent: Largest distance of two tracks' predictions that may be one blob (sensor
            units), > 0.
        merge_area_std: Std of a blob member's area fraction around ½, >= 0.
        merge_odds: Prior odds of a merged blob against two separate particles for a pair within
            ``merge_extent``, > 0.
        max_exact: Clusters of at most this many tracks are exact; larger ones use loopy belief
            propagation without merged blobs.
        coalescence_guard: A track that shares its cluster with other tracks takes the frame's
            optimal assignment instead of its mixture (unless a merged blob is its most probable
            hypothesis): the mixtures of competing tracks pull them together (module docstring).
            False: every settled track's PDA update.
        rigid_merge: The members of a merged blob keep the offset between their last estimates
            (a rigid pair: their relative motion is not extrapolated while the blob hides it;
            module docstring, *Merged blobs*). False: the offset between their predictions.
        **gnn_kwargs: Every other argument of [`GnnAgent`][agents.gnn.agent.GnnAgent] (``p_gate``,
            ``max_misses``, ``region_margin``, ``velocity_prior``, ``recovery_inflation``,
            ``recovery_cap_motion``, ..., and the predictor's keywords), except ``blob_extent`` and
            ``assignment`` (the merged blobs and the association are this tracker's own).
    """

    # the associator's settings and per-episode figures, shown as the tracker's own (read-only)
    p_detect = _FromAssociator()
    clutter_density = _FromAssociator()
    p_detect_arg = _FromAssociator()
    clutter_density_arg = _FromAssociator()
    min_clutter_rate = _FromAssociator()
    merge_model = _FromAssociator()
    merge_extent = _FromAssociator()
    merge_area_std = _FromAssociator()
    merge_odds = _FromAssociator()
    max_exact = _FromAssociator()
    coalescence_guard = _FromAssociator()
    rigid_merge = _FromAssociator()
    approximate_tracks = _FromAssociator()
    blob_splits = _FromAssociator()
    last_cluster_tracks = _FromAssociator()
    last_p_seen = _FromAssociator()

    def __init__(
        self,
        predictor: str | Predictor = "kf-ca",
        *,
        p_detect: float | None = None,
        clutter_density: float | None = None,
        min_clutter_rate: float = MIN_CLUTTER_RATE,
        merge_model: bool = True,
        merge_extent: float = MERGE_EXTENT,
        merge_area_std: float = MERGE_AREA_STD,
        merge_odds: float = 1.0,
        max_exact: int = MAX_EXACT,
        coalescence_guard: bool = True,
        rigid_merge: bool = True,
        **gnn_kwargs: Any,
    ):
        for name in ("blob_extent", "assignment"):
            if name in gnn_kwargs:
                raise ValueError(
                    f"jpda has no argument {name!r}: its association is probabilistic and merged "
                    "blobs are its merge_model (merge_extent, merge_area_std, merge_odds)"
                )
        caps = {
            k: gnn_kwargs.pop(k) for k in ("recovery_cap_motion", "recovery_cap_noise") if k in gnn_kwargs
        }
        associator = JpdaAssociator(
            p_detect=p_detect,
            clutter_density=clutter_density,
            min_clutter_rate=min_clutter_rate,
            merge_model=merge_model,
            merge_extent=merge_extent,
            merge_area_std=merge_area_std,
            merge_odds=merge_odds,
            max_exact=max_exact,
            coalescence_guard=coalescence_guard,
            rigid_merge=rigid_merge,
            **caps,
        )
        super().__init__(predictor, associator=associator, owner=type(self), **gnn_kwargs)
        self.recovery_cap_motion = associator.second_chance.cap_motion
        self.recovery_cap_noise = associator.second_chance.cap_noise
