"""The global-nearest-neighbour tracker: any Gaussian predictor, Hungarian association, births,
deletions and the nozzle-bar roll-out."""

from agents.gnn.agent import GnnAgent
from track_envs.infra.lazy import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(__name__, __file__)
