"""The bootstrap particle filter of Jung et al. (2019) with Brownian, constant-velocity or LSTM
displacement models."""

from agents.particle.agent import ParticleFilterAgent

__all__ = ["ParticleFilterAgent"]
