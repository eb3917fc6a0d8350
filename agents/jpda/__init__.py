"""Joint probabilistic data association (Fortmann, Bar-Shalom, Scheffe: Sonar tracking of multiple
targets using joint probabilistic data association, 1983): gating clusters and the marginal
association probabilities of tracks and detections."""

from agents.jpda.clusters import GateClusters, gate_clusters
from agents.jpda.marginals import (
    MAX_EXACT,
    Marginals,
    association_marginals,
    cluster_marginals,
    jpda_marginals,
)
from agents.jpda.weights import EventWeights, gaussian_log_likelihood, jpda_log_weights
from track_envs.infra.lazy import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(__name__, __file__)
