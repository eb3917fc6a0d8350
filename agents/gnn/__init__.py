"""The global-nearest-neighbour tracker: any Gaussian predictor, Hungarian association, births,
deletions and the nozzle-bar roll-out."""

from agents.gnn.agent import GnnAgent

__all__ = ["GnnAgent"]
