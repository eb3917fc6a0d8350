"""The bootstrap particle filter of Jung et al. (2019) with Brownian, constant-velocity or LSTM
displacement models."""

from agents.particle.agent import ParticleFilterAgent
from track_envs.infra.lazy import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(__name__, __file__)
