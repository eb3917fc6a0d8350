"""The sensor model from the data: noise, motion, velocity prior, coasting, detection probability,
clutter and merges from the detections.

[`estimate_sensor_model`][agents.estimate_sensor_model]
(`agents.sensor_model.estimate`) estimates the measurement noise, the process
noise, the velocity prior and the coasting length of a Kalman tracker, the detection probability and the
clutter density (`agents.sensor_model.detection`) and jpda's merge extent
(`agents.sensor_model.merging`) from its own confident tracks (what
``track run`` does when no noise is declared, ``run_agent(..., estimate_sensor_model=True)``);
`agents.sensor_model.diagnostics` names the figures of a run that looks
wrong; `track run` prints and writes the estimate.

Words: *calibration* in this project is a learned model's stated uncertainty made to match its
errors (`predictors.training.calibration`); estimating the sensor from a
file is the *sensor model* (this package).
"""

from agents.sensor_model.diagnostics import run_warnings
from agents.sensor_model.estimate import SensorModelEstimate, estimate_sensor_model
from track_envs.infra.lazy import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(__name__, __file__)
