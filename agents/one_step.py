"""One-step prediction with true associations: a predictor scored inside the bench loop.

Pollithy, Reith-Braun, Pfaff, Hanebeck, "Estimating Uncertainties of Recurrent Neural Networks in
Application to Multitarget Tracking" (2020), Sec. V-B, D, E, score the motion models apart from
the tracker: every track is fed the measurements of its own particle ("using the ground truth
associations"), and each prediction ``N(ŷ, Σ)`` is compared with the measurement that followed.

[`OneStepAgent`][agents.one_step.OneStepAgent] does that frame by frame on any point env with truth. It is an
*oracle*:
unlike a tracker it reads the frame's ``info["detection_ids"]`` (the truth id behind each
detection row) through [`OneStepAgent.observe_truth`][agents.one_step.OneStepAgent.observe_truth], which the
bench runner calls before every ``act`` for agents that declare the ``needs_truth`` trait. Per frame:

1. every track predicts (one batched ``predict``);
2. tracks whose particle has a detection are scored against it and updated with it; tracks whose
   particle is visible but undetected coast (fed their prediction, not scored); the others end;
3. particles detected for the first time start tracks (Kalman filters from the mean first
   velocity of the tracks seen so far, as [`agents.gnn.agent.GnnAgent`][agents.gnn.agent.GnnAgent]'s learnt
   flow prior).

The report is the true association (e1 = e2 = 0; when more tracks live than the report has
rows, the first ``max_tracks`` are reported and every track is still scored). Its scores, from
`episode_metrics`, are the per-track error distribution
([`TrackErrorDistribution`][track_envs.metrics.TrackErrorDistribution]),
the reliability curve of the covariances as predicted (``reliability@p``) and divided by the
predictor's calibration factor ``r`` (``reliability_raw@p``; predictors that do not declare the
``CALIBRATION`` capability have ``r = 1``),
and the bounding-box area of the uncalibrated covariance against the track's number of
observations ([`AleatoricArea`][track_envs.metrics.AleatoricArea]; for nll-lstm the network's
aleatoric variance).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agents.base import AgentCapability, AgentTraits
from predictors.base import Capability, Predictor, capability, reset_predictor
from predictors.registry import resolve_predictor
from track_envs.contracts.observation import check_observation
from track_envs.contracts.report import pack_report
from track_envs.metrics.aleatoric import AleatoricArea
from track_envs.metrics.prediction import Reliability
from track_envs.metrics.track_error import TrackErrorDistribution
from track_envs.values.types import SensorSpec

#: Confidence levels of the reliability curves (the 0.05 grid of the cumulative histogram, its
#: ends, and the gate level 0.999 of the calibration).
LEVELS = (0.01, *np.round(np.arange(1, 20) * 0.05, 10), 0.99, 0.999)


class OneStepAgent:
    """Runs a predictor with true associations and scores its one-step predictions.

    Args:
        predictor: Registered predictor name or a Predictor object.
        velocity_prior: Start Kalman tracks from the mean first velocity of the episode's tracks
            (default True); False keeps the predictor's own initial velocity.
        **predictor_kwargs: Passed to a predictor given by name (e.g. ``samples`` of mc-lstm).
    """

    #: The bench runner hands this agent each frame's ``info`` (see
    #: [`observe_truth`][agents.one_step.OneStepAgent.observe_truth]), and it
    #: is built with ``predictor=`` (a Gaussian predictor's name or object).
    traits = AgentTraits(needs_truth=True, takes_predictor=True)
    capabilities = frozenset({AgentCapability.TRUTH_OBSERVER})

    def __init__(
        self, predictor: str | Predictor = "kf-ca", *, velocity_prior: bool = True, **predictor_kwargs: Any
    ):
        if not isinstance(velocity_prior, bool | np.bool_):
            raise ValueError(f"velocity_prior must be True or False, got {velocity_prior!r}")
        self.velocity_prior = bool(velocity_prior)
        self.predictor: Predictor = resolve_predictor(predictor, owner=type(self), **predictor_kwargs)
        calibrated = capability(self.predictor, Capability.CALIBRATION)
        self.scale = 1.0 if calibrated is None else float(calibrated.calibration_scale)
        self._with_prior = capability(self.predictor, Capability.VELOCITY_PRIOR)
        self.errors = TrackErrorDistribution()
        self.reliability = Reliability(LEVELS)
        self.reliability_raw = Reliability(LEVELS)
        self.area = AleatoricArea()
        self._spec: SensorSpec | None = None
        self._detection_ids: NDArray[np.int64] | None = None
        self._visible: NDArray[np.int64] = np.zeros(0, dtype=np.int64)

    def reset(self, spec: SensorSpec, *, seed: int | None = None) -> None:
        """Start an episode: no tracks, empty scores; ``seed`` seeds the predictor's stream."""
        self._spec = spec
        reset_predictor(self.predictor, spec, np.random.default_rng(np.random.SeedSequence(seed).spawn(1)[0]))
        self._state: Any = None
        self._ids = np.zeros(0, dtype=np.int64)
        self._age = np.zeros(0, dtype=np.int64)
        self._first = np.zeros((0, spec.dim))
        self._v_sum = np.zeros(spec.dim)
        self._v_n = 0
        for metric in (self.errors, self.reliability, self.reliability_raw, self.area):
            metric.reset()
        self._detection_ids = None

    def observe_truth(self, info: Mapping[str, Any]) -> None:
        """Take the truth of the frame the next [`act`][agents.one_step.OneStepAgent.act] answers (its
        ``detection_ids`` and the ids of the visible particles)."""
        self._detection_ids = np.asarray(info["detection_ids"], dtype=np.int64)
        truth = info["truth"]
        ids = np.asarray(truth["ids"], dtype=np.int64)
        self._visible = np.sort(ids[(ids >= 0) & np.asarray(truth["visible"], dtype=bool)])

    def act(self, obs: Mapping[str, NDArray]) -> dict[str, NDArray]:
        """Predict, score, update, end and start tracks by the true association; the report."""
        if self._spec is None:
            raise RuntimeError("OneStepAgent needs reset(spec) before act(obs)")
        live, _ = check_observation(obs, self._spec)
        if self._detection_ids is None:
            raise RuntimeError("OneStepAgent needs observe_truth(info) of the frame before act(obs)")
        det = np.asarray(obs["detections"], dtype=np.float64)
        rows = live[self._detection_ids[live] >= 0]
        ids_now, first = np.unique(self._detection_ids[rows], return_index=True)
        rows = rows[first]
        z_now = det[rows]
        estimate = np.zeros((0, self._spec.dim))
        detection = np.zeros(0, dtype=np.int64)
        keep = np.zeros(0, dtype=bool)
        if len(self._ids):
            self._state, pred = self.predictor.predict(self._state)
            pos = np.minimum(np.searchsorted(ids_now, self._ids), max(len(ids_now) - 1, 0))
            seen = (ids_now[pos] == self._ids) if len(ids_now) else np.zeros(len(self._ids), bool)
            self._score(pred.mean[seen], pred.cov[seen], z_now[pos[seen]], self._ids[seen], self._age[seen])
            z_in = np.where(seen[:, None], z_now[pos] if len(ids_now) else pred.mean, pred.mean)
            self._state = self.predictor.update(self._state, z_in, seen)
            self._learn_velocity(seen, z_in)
            self._age = self._age + seen
            visible = np.isin(self._ids, self._visible)
            keep = seen | visible
            estimate = z_in[keep]
            detection = np.where(seen, rows[pos] if len(rows) else -1, -1)[keep]
        born = ~np.isin(ids_now, self._ids)
        self._births(keep, z_now[born], ids_now[born])
        positions = np.concatenate([estimate, z_now[born]])
        detection = np.concatenate([detection, rows[born]])
        self._detection_ids = None
        m = self._spec.max_tracks  # a burst beyond the report's rows: the scores keep every track
        return pack_report(self._ids[:m], positions[:m], detection[:m], m)

    def _score(
        self,
        mean: NDArray[np.float64],
        cov: NDArray[np.float64],
        target: NDArray[np.float64],
        ids: NDArray[np.int64],
        age: NDArray[np.int64],
    ) -> None:
        if not len(ids):
            return
        self.errors.update(mean, target, ids)
        self.reliability.update(mean, cov, target)
        raw = cov / self.scale
        self.reliability_raw.update(mean, raw, target)
        self.area.update(raw, age)

    def _learn_velocity(self, seen: NDArray[np.bool_], z: NDArray[np.float64]) -> None:
        second = seen & (self._age == 1)
        if second.any() and self._spec is not None:
            self._v_sum += ((z[second] - self._first[second]) / self._spec.dt).sum(axis=0)
            self._v_n += int(second.sum())

    def _births(self, keep: NDArray[np.bool_], z: NDArray[np.float64], ids: NDArray[np.int64]) -> None:
        n_keep = int(keep.sum())
        if n_keep < len(keep):
            self._state = self._state.take(keep) if n_keep else None
            self._ids, self._age, self._first = self._ids[keep], self._age[keep], self._first[keep]
        if not len(ids):
            return
        if self.velocity_prior and self._with_prior is not None and self._v_n:
            v = np.broadcast_to(self._v_sum / self._v_n, z.shape)
            born = self._with_prior.start(z, velocity=v)
        else:
            born = self.predictor.start(z)
        self._state = born if self._state is None else type(born).concat([self._state, born])
        self._ids = np.concatenate([self._ids, ids])
        self._age = np.concatenate([self._age, np.ones(len(ids), dtype=np.int64)])
        self._first = np.concatenate([self._first, z])

    def episode_metrics(self) -> dict[str, float]:
        """The scores of the episode so far: track errors, both reliability curves, areas."""
        out = self.errors.compute()
        out |= {k: v for k, v in self.reliability.compute().items()}
        raw = self.reliability_raw.compute()
        out |= {k.replace("reliability@", "reliability_raw@"): v for k, v in raw.items() if "@" in k}
        out["calibration_error_raw"] = raw["calibration_error"]
        out["nees_raw"] = raw["nees"]
        out["calibration_scale"] = self.scale
        return out | self.area.compute()
