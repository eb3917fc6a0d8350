"""The displacement LSTM of Jung et al. (2019): network, inference, the particle displacement model
and the training recipe."""

from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from predictors.displacement_lstm.inference import DisplacementLSTM, shipped_displacement_weights
    from predictors.displacement_lstm.model import LSTMDisplacement
    from predictors.displacement_lstm.network import DisplacementLSTMNet

#: The module of each name loaded on first access (``__getattr__``), so that importing
#: the package stays light.
_LAZY: dict[str, str] = {
    "DisplacementLSTM": "predictors.displacement_lstm.inference",
    "shipped_displacement_weights": "predictors.displacement_lstm.inference",
    "LSTMDisplacement": "predictors.displacement_lstm.model",
    "DisplacementLSTMNet": "predictors.displacement_lstm.network",
}

__all__ = [
    "DisplacementLSTM",
    "DisplacementLSTMNet",
    "LSTMDisplacement",
    "shipped_displacement_weights",
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
