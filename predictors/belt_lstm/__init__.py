"""The belt LSTMs of Pollithy et al. (2020): network, numpy/compiled inference, the batched predictor
(MSE, NLL and MC-dropout heads), the roll-out to the nozzle bar and the training recipe."""

from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING, Any

from predictors.belt_lstm.predictor import LSTMPredictor

if TYPE_CHECKING:
    from predictors.belt_lstm.network import BeltLSTMNet
    from predictors.belt_lstm.predictor import shipped_weights

#: The module of each name loaded on first access (``__getattr__``), so that importing
#: the package stays light.
_LAZY: dict[str, str] = {
    "BeltLSTMNet": "predictors.belt_lstm.network",
    "shipped_weights": "predictors.belt_lstm.predictor",
}

__all__ = [
    "BeltLSTMNet",
    "LSTMPredictor",
    "shipped_weights",
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
