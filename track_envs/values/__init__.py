"""Value types shared by environments, agents and files: the sensor specification and Gaussians
(:mod:`~track_envs.values.types`), detections, tracks and pose streams. Imports only
:mod:`track_envs.infra`."""
