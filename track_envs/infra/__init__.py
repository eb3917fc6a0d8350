"""Shared infrastructure of every layer: the compiled-kernel decorator, registries, argument checks
and the assignment solvers. Imports nothing else of :mod:`track_envs`."""
