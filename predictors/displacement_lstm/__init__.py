"""The displacement LSTM of Jung et al. (2019): network, inference, the particle displacement model
and the training recipe."""

from __future__ import annotations

from typing import TYPE_CHECKING

from track_envs.infra.lazy import lazy_exports

if TYPE_CHECKING:
    from predictors.displacement_lstm.inference import DisplacementLSTM, shipped_displacement_weights
    from predictors.displacement_lstm.model import LSTMDisplacement
    from predictors.displacement_lstm.network import DisplacementLSTMNet

__getattr__, __dir__, __all__ = lazy_exports(__name__, __file__)
