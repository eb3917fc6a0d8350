"""Linear assignment: the dense solver, the reduction of a gated problem to it, and the solvers of
sparse lists of pairs.

* [`lone_pairs`][track_envs.infra.assignment.lone_pairs]: assignment *with misses* (every row may stay
  unassigned at a miss cost ``γ``) for gated problems given as a cost matrix: the lone pairs are
  split off, the rest becomes the ``[C | M]`` problem, and
  [`solve_split`][track_envs.infra.assignment.lone_pairs.solve_split] /
  [`min_cost_with_misses`][track_envs.infra.assignment.lone_pairs.min_cost_with_misses] solve it with
  ``scipy.optimize.linear_sum_assignment``. GOSPA and the dense assigners use it.
* [`shortest_augmenting_path`][track_envs.infra.assignment.shortest_augmenting_path]: the dense solver itself,
compiled,
  step for step as scipy's ``rectangular_lsap.cpp``. The compiled metric kernels (GOSPA, CLEAR MOT
  events) call a solver from inside numba, where scipy cannot be called, and must return scipy's
  assignment also where several are optimal: py-motmetrics and TrackEval break ties that way, and
  the metric values are checked against them bit for bit.
* [`components`][track_envs.infra.assignment.components]: the problem with misses given as a sparse list
  of admissible pairs (never an ``n × m`` array): lone pairs, then every connected component of
  the pairs solved exactly on its own, by the dense solver or, for a component too large for a
  dense matrix, by [`sparse_path`][track_envs.infra.assignment.sparse_path] (shortest augmenting paths on
  the pairs). The trackers' association uses it; [`greedy`][track_envs.infra.assignment.greedy] is
  the greedy assignment of such a list.

The first two are not two versions of one algorithm: the first reduces a problem (and calls a
dense solver), the second is the dense solver; the split/merge kernels of the first also run
inside compiled code, on top of the second.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from track_envs.infra.lazy import lazy_exports

if TYPE_CHECKING:
    from track_envs.infra.assignment.lone_pairs import min_cost_with_misses, solve_split
    from track_envs.infra.assignment.shortest_augmenting_path import linear_sum_assignment

__getattr__, __dir__, __all__ = lazy_exports(__name__, __file__)
