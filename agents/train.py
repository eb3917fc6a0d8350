"""The ``track-train`` console script: :mod:`predictors.training.cli` plus the tracker-side steps.

Training, calibration and the model file are in :mod:`predictors.training`; the ``lstm`` model's
covariance line search runs a tracker, so it is added here (imports run track_envs ← predictors ←
agents).
"""

from __future__ import annotations

from collections.abc import Sequence


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``track-train`` (see ``track-train --help``)."""
    from agents.lstm_line_search import lstm_tuner
    from predictors.training.cli import main as train_main

    return train_main(argv, tuners={"lstm": lstm_tuner})


if __name__ == "__main__":
    raise SystemExit(main())
