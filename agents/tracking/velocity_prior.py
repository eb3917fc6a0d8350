"""The velocity prior new tracks start from, learnt online from the young tracks (the flow).

Every frame, each young track (updated ``YOUNG_STREAK`` = 3–6 times in a row) gives one sample,
its frame-to-frame velocity; the last ``FLOW_WINDOW`` samples, over as many frames as it takes to
collect them, give the prior's median ``v̄`` and robust variance ``(1.4826 MAD)²``
([`agents.tracking._upkeep_kernels.learn_flow`][agents.tracking._upkeep_kernels.learn_flow]: re-estimated with
every new sample while there are few, every ``FLOW_WINDOW / 8`` samples once the window is full). On a belt
this is the flow where particles enter, so a track's second measurement is predicted where the flow takes it.
The prior forms from ``MIN_FLOW_SAMPLES`` samples. A new track starts from ``v̄`` with the covariance

.. math::

    \\operatorname{diag}\\big(4 σ^2 + (0.1 \\lVert v̄ \\rVert)^2\\big)

— the spread of young tracks doubled, with a floor of 10 % of the flow speed: the prior must
admit the particle that deviates, not just the typical one. Until the prior is learnt new tracks
start from a fallback velocity when one is given (e.g. the belt speed), else from the predictor's
default.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from agents.tracking import _upkeep_kernels as _kernels

#: Update streaks (consecutive updates) of the young tracks the velocity prior is learnt from.
YOUNG_STREAK = (3, 6)
#: Velocity samples (one per young track and frame) the learnt prior is taken over, newest first.
FLOW_WINDOW = 128
#: Fewest samples for the learnt prior to be used.
MIN_FLOW_SAMPLES = 3


@dataclass(frozen=True)
class VelocityPriorState:
    """The velocity prior new tracks start from (read-only copy).

    Attributes:
        mean: (D,) prior velocity ``v̄``, or None when new tracks start from the predictor's default.
        variance: (D,) robust variance of the samples per axis (before the widening applied at a
            track's start), or None.
        n_samples: Velocity samples in the learnt estimate (0 when not learning).
        source: ``"learnt"``, ``"fallback"`` (``velocity_fallback`` until enough samples),
            ``"fixed"`` (a given ``velocity_prior``) or ``"none"``.
    """

    mean: NDArray[np.float64] | None
    variance: NDArray[np.float64] | None
    n_samples: int
    source: str


class FlowPrior:
    """The prior velocity of new tracks in one episode: fixed, learnt (with a fallback), or none.

    Args:
        velocity_prior: ``"auto"`` (learnt), ``None`` (none) or a fixed velocity (D,).
        velocity_fallback: With ``"auto"``, the velocity (D,) until the prior is learnt, or None.
        dim: ``D``, the measurement dimension.

    Raises:
        ValueError: for a fixed velocity or a fallback that is not a finite vector of shape (D,).
    """

    def __init__(
        self, velocity_prior: str | NDArray | None, velocity_fallback: NDArray[np.float64] | None, dim: int
    ):
        self.learning = isinstance(velocity_prior, str)
        self.mean: NDArray | None = None
        self.variance: NDArray | None = None
        self.speed = 0.0
        self.birth_cov: NDArray | None = None
        self._samples = np.zeros((FLOW_WINDOW, dim))
        self.n_samples = 0
        self._head = 0
        self._fresh = 0
        if velocity_prior is not None and not isinstance(velocity_prior, str):
            v = np.asarray(velocity_prior, dtype=np.float64)
            if v.shape != (dim,):
                raise ValueError(f"velocity_prior must have shape ({dim},), got {v.shape}")
            self._set(v, None)
        elif self.learning and velocity_fallback is not None:
            if velocity_fallback.shape != (dim,) or not np.all(np.isfinite(velocity_fallback)):
                raise ValueError(
                    f"velocity_fallback must be a finite vector of shape ({dim},), "
                    f"got {velocity_fallback.tolist()}"
                )
            self._set(velocity_fallback.copy(), None)

    def motion_per_frame(self, dt: float) -> float:
        """``‖v̄‖ dt``, the flow's motion per frame (0 while there is no prior)."""
        return self.speed * dt if self.mean is not None else 0.0

    def learn(
        self, estimate: NDArray[np.float64], last: NDArray[np.float64], young: NDArray[np.bool_], dt: float
    ) -> None:
        """Add the velocities ``(estimate − last) / dt`` of the ``young`` tracks to the samples, and
        re-estimate the prior once there are ``MIN_FLOW_SAMPLES``.

        New tracks are born where young tracks were born a few frames ago, so the velocities of
        young tracks are the right prior for them (on a belt: the entry speed, not the mean flow).
        """
        flow = _kernels.learn_flow(
            self._samples,
            self.n_samples,
            self._head,
            self._fresh,
            estimate,
            last,
            young,
            dt,
            MIN_FLOW_SAMPLES,
        )
        self.n_samples, self._head, self._fresh = flow.n_samples, flow.head, flow.fresh
        if flow.updated:
            self._set(flow.median, flow.variance)

    def state(self) -> VelocityPriorState:
        """A read-only copy: mean, spread, samples and where the prior comes from."""
        if not self.learning:
            source = "none" if self.mean is None else "fixed"
        elif self.n_samples >= MIN_FLOW_SAMPLES:
            source = "learnt"
        else:
            source = "none" if self.mean is None else "fallback"
        return VelocityPriorState(
            mean=None if self.mean is None else self.mean.copy(),
            variance=None if self.variance is None else self.variance.copy(),
            n_samples=self.n_samples,
            source=source,
        )

    def _set(self, mean: NDArray[np.float64], variance: NDArray[np.float64] | None) -> None:
        """Set the prior and what new tracks start from (module docstring)."""
        self.mean, self.variance = mean, variance
        self.speed = float(np.sqrt(mean @ mean))
        self.birth_cov = None if variance is None else np.diag(4.0 * variance + (0.1 * self.speed) ** 2)
