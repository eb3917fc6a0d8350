"""A tracker that calibrates itself to the data: noise, motion and velocity prior from the detections.

:func:`calibrate` (:mod:`agents.self_calibration.calibrate`) estimates the measurement noise, the
process noise and the velocity prior of a Kalman tracker from its own confident tracks;
:mod:`agents.self_calibration.diagnostics` names the figures of a run that looks wrong.
"""

from agents.self_calibration.calibrate import SelfCalibration, calibrate
from agents.self_calibration.diagnostics import run_warnings

__all__ = ["SelfCalibration", "calibrate", "run_warnings"]
