"""Synthetic detection streams with known truth, for checks that no env scene isolates: each module
builds a :class:`~track_envs.values.types.SensorSpec`, the observations a tracker consumes and the truth
to score it by."""
