"""Particle displacement models: relative displacement geometry (rotation, speed) and the models a
particle filter moves its particles with."""
