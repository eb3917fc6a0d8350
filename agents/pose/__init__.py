"""Multi-person pose trackers: the pose-tracking loop of Okada et al. (2020) with a pluggable motion
hypothesis ([`.tracker`][agents.pose.tracker]), its constant-velocity agent (``pose-baseline``) and the SMC
pose tracker ([`.smc`][agents.pose.smc], ``pose-smc``)."""

from agents.pose.smc import PoseSmcAgent
from agents.pose.tracker import PoseBaselineAgent, PoseTracker, PoseTrackingOptions
from track_envs.infra.lazy import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(__name__, __file__)
