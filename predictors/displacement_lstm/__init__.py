"""The displacement LSTM of Jung et al. (2019): network, inference, the particle displacement model
and the training recipe."""

from __future__ import annotations

from typing import TYPE_CHECKING

from track_envs.infra.lazy import lazy_exports

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


__getattr__, __dir__ = lazy_exports(__name__, _LAZY, __all__)
