"""Tracking recorded files (the ``track run`` engine): any agent over a detection or pose stream.

* [`run_agent`][agents.run_agent] (`.points`) — a point or box stream
([`track_envs.values.Detections`][track_envs.Detections])
  through a registered agent, frame by frame, into [`Tracks`][track_envs.Tracks] (with the
  sensor model estimated from the data when asked: ``estimate_sensor_model=True``);
* [`run_pose_agent`][agents.run_pose_agent] (`.poses`) — a pose stream through a pose
tracker;
* [`file_agents`][agents.files.file_agents] / [`check_file_agent`][agents.files.check_file_agent]
(`.kinds`) — which agents can run on a kind
  of file, by their declared traits.
"""

from agents.files.kinds import check_file_agent, file_agents
from agents.files.points import run_agent
from agents.files.poses import run_pose_agent
from track_envs.infra.lazy import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(__name__, __file__)
