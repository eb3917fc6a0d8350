"""Frozen value objects shared by environments, predictors and agents.

Everything here is a small immutable value with documented shapes. ``n`` is a number of
tracks (or targets), ``D`` the measurement dimension (2 for the point environments).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class SensorSpec:
    """Everything an agent may know about the sensor of an environment.

    Attributes:
        dt: Time between frames in seconds.
        dim: Dimension ``D`` of a point measurement (2 for every point env).
        noise_std: Standard deviation of the Gaussian measurement noise per axis that the sensor
            declares, in sensor units (metres for the belt sorter): what a tracker is told, and
            not necessarily what the env adds (a replay of real centroids adds none but declares
            the camera's noise).
        p_detect: Probability that a visible target gives a detection in a frame.
        clutter_rate: Expected number of clutter (false) detections per frame, uniform over
            the observed region.
        region_low: Lower corner of the observed region, length ``D``.
        region_high: Upper corner of the observed region, length ``D``.
        max_detections: Number of rows of the padded ``"detections"`` observation.
        max_tracks: Number of rows of the report (the action).
        units: Name of the sensor unit, for plots and tables.
        sorting_line: Where a sorter acts on the targets after they leave the observed region:
            the coordinate ``x = sorting_line`` (axis 0, the transport direction, downstream of
            ``region_high[0]``) of the nozzle bar of an optical belt sorter, or ``None`` where
            there is none. A tracker that knows it can predict when and where across the belt
            each target crosses it (the report's optional sorting channel,
            `track_envs.contracts.report`).
    """

    dt: float
    dim: int
    noise_std: float
    p_detect: float
    clutter_rate: float
    region_low: tuple[float, ...]
    region_high: tuple[float, ...]
    max_detections: int
    max_tracks: int
    units: str = "m"
    sorting_line: float | None = None

    def __post_init__(self) -> None:
        if not (self.dt > 0 and np.isfinite(self.dt)):
            raise ValueError(f"SensorSpec.dt must be a positive finite number of seconds, got {self.dt!r}")
        if self.dim < 1:
            raise ValueError(f"SensorSpec.dim must be >= 1, got {self.dim!r}")
        if len(self.region_low) != self.dim or len(self.region_high) != self.dim:
            raise ValueError(
                f"SensorSpec region corners must have length dim={self.dim}, got "
                f"{len(self.region_low)} and {len(self.region_high)}"
            )
        if any(lo >= hi for lo, hi in zip(self.region_low, self.region_high, strict=True)):
            raise ValueError(
                f"SensorSpec.region_low {self.region_low} must be below region_high {self.region_high}"
            )
        if self.noise_std < 0:
            raise ValueError(f"SensorSpec.noise_std must be >= 0, got {self.noise_std!r}")
        if not 0.0 <= self.p_detect <= 1.0:
            raise ValueError(f"SensorSpec.p_detect must be in [0, 1], got {self.p_detect!r}")
        if self.clutter_rate < 0:
            raise ValueError(f"SensorSpec.clutter_rate must be >= 0, got {self.clutter_rate!r}")
        if self.max_detections < 1 or self.max_tracks < 1:
            raise ValueError(
                "SensorSpec.max_detections and max_tracks must be >= 1, got "
                f"{self.max_detections!r} and {self.max_tracks!r}"
            )
        if self.sorting_line is not None and not (
            np.isfinite(self.sorting_line) and self.sorting_line > self.region_high[0]
        ):
            raise ValueError(
                f"SensorSpec.sorting_line must be a finite coordinate downstream of region_high[0]="
                f"{self.region_high[0]!r} (or None), got {self.sorting_line!r}"
            )

    @property
    def measurement_cov(self) -> FloatArray:
        """Measurement noise covariance ``R = noise_std² · I_D``, shape (D, D)."""
        return np.eye(self.dim) * self.noise_std**2

    @property
    def region_size(self) -> FloatArray:
        """Extent of the observed region per axis, shape (D,)."""
        return np.asarray(self.region_high, dtype=np.float64) - np.asarray(self.region_low, dtype=np.float64)

    def contains(self, points: NDArray[np.floating]) -> NDArray[np.bool_]:
        """Whether each point of ``points`` (n, D) lies inside the observed region, shape (n,)."""
        p = np.asarray(points, dtype=np.float64)
        lo = np.asarray(self.region_low)
        hi = np.asarray(self.region_high)
        return np.all((p >= lo) & (p <= hi), axis=-1)


@dataclass(frozen=True)
class Gaussian:
    """A batch of Gaussians: ``mean`` (n, D) and ``cov`` (n, D, D).

    Predictors return the predicted measurement of every track as one ``Gaussian``.
    """

    mean: FloatArray
    cov: FloatArray = field(repr=False)

    def __post_init__(self) -> None:
        m = np.asarray(self.mean)
        c = np.asarray(self.cov)
        if m.ndim != 2 or c.ndim != 3 or c.shape != (m.shape[0], m.shape[1], m.shape[1]):
            raise ValueError(
                f"Gaussian needs mean (n, D) and cov (n, D, D), got mean {m.shape} and cov {c.shape}"
            )

    def __len__(self) -> int:
        return int(np.asarray(self.mean).shape[0])

    @property
    def dim(self) -> int:
        """Dimension ``D`` of each Gaussian."""
        return int(np.asarray(self.mean).shape[1])

    def take(self, rows: NDArray[np.integer] | NDArray[np.bool_]) -> Gaussian:
        """The Gaussians at ``rows`` (integer indices or a boolean mask)."""
        return Gaussian(np.asarray(self.mean)[rows], np.asarray(self.cov)[rows])
