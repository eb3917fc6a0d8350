"""The probabilistic pose predictor of Okada et al. (2020): network, batched predictor and training recipe."""

from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from predictors.pose_lstm.motion import SmcPoseMotion, SmcSettings
    from predictors.pose_lstm.network import PosePredictorNet
    from predictors.pose_lstm.predictor import PosePredictor

#: The module of each name loaded on first access (``__getattr__``), so that importing
#: the package stays light.
_LAZY: dict[str, str] = {
    "SmcPoseMotion": "predictors.pose_lstm.motion",
    "SmcSettings": "predictors.pose_lstm.motion",
    "PosePredictorNet": "predictors.pose_lstm.network",
    "PosePredictor": "predictors.pose_lstm.predictor",
}

__all__ = [
    "PosePredictor",
    "PosePredictorNet",
    "SmcPoseMotion",
    "SmcSettings",
]


def __getattr__(name: str) -> Any:
    """Import ``name`` from its module on first access (the module stays unloaded until then)."""
    home = _LAZY.get(name)
    if home is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = vars(import_module(home))[name]
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
