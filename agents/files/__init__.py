"""Tracking recorded files (the ``track run`` engine): any agent over a detection or pose stream.

* :func:`run_agent` (:mod:`.points`) — a point or box stream (:class:`track_envs.values.Detections`)
  through a registered agent, frame by frame, into :class:`~track_envs.values.Tracks` (with the
  sensor model estimated from the data when asked: ``estimate_sensor_model=True``);
* :func:`run_pose_agent` (:mod:`.poses`) — a pose stream through a pose tracker;
* :func:`file_agents` / :func:`check_file_agent` (:mod:`.kinds`) — which agents can run on a kind
  of file, by their declared traits.
"""

from agents.files.kinds import check_file_agent, file_agents
from agents.files.points import run_agent
from agents.files.poses import run_pose_agent

__all__ = ["check_file_agent", "file_agents", "run_agent", "run_pose_agent"]
