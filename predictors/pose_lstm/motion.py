"""The SMC pose motion of Okada et al. (2020): particles of pose queues moved by the pose LSTM.

Okada, Takenaka and Taniguchi, "Multi-person Pose Tracking using Sequential Monte Carlo with
Probabilistic Neural Pose Predictor" (ICRA 2020), Sec. II and IV, Algorithm 1. This module is the
motion hypothesis, [`SmcPoseMotion`][predictors.pose_lstm.motion.SmcPoseMotion] (a
[`PoseMotion`][predictors.pose.base.PoseMotion]); the loop (OKS scores, bipartite matching with a threshold,
lifetimes, births, ``F_max`` filters) is [`agents.pose.tracker.PoseTracker`][agents.pose.tracker.PoseTracker],
and the agent ``pose-smc`` is [`agents.pose.smc.PoseSmcAgent`][agents.pose.smc.PoseSmcAgent].

Each active filter ``k`` holds ``P`` particles; particle ``n`` is a queue of the last ``L`` poses
``z^{(k,n)}_{t−L:t−1}`` (per keypoint ``(x, y, v)``), and the filter keeps the queue of its matched
observations ``x_{t−L+1:t}`` (zeros in frames without a match and for undetected keypoints).
Every frame, batched over filters × particles × keypoints (no Python loop over any of them):

1. **proposal** (eq. 5): every particle's queue goes through the pose predictor
   ([`predictors.pose_lstm.predictor.PosePredictor`][predictors.pose_lstm.predictor.PosePredictor]), one
   dropout mask per sequence (epistemic; its decisions 16-bit random fields,
   [`dropout_fields`][predictors.pose_lstm.predictor.dropout_fields]) and a Gaussian draw
   ``z = a + s · (μ + σ ε)`` (aleatoric) — ``F_t × P × 17`` pointwise sequences;
2. **likelihood** (eq. 4): ``OKS(x_j, z^{(k,n)})`` of every particle against every detection
   (over the keypoints the detection holds and the particle has an anchor for);
3. **matching score** (footnote 2): elite weights — the top ``e = 15 %`` particles by OKS weigh 1,
   the others 0 — so ``d(j, k)`` is the mean OKS of the elite particles of filter ``k`` for pose ``j``;
4. **update** (Algorithm 1, ℓ19–21): every queue takes its prediction ``z_t``; a matched filter
   resamples (eq. 3) with the weights of eq. (7), ``w ∝ elite(OKS) / q``, ``q`` the probability
   (α or 1 − α) of the history the particle was proposed from, and then *selects* (eq. 6): each
   particle keeps its own queue with probability α or takes the observation queue
   ``x_{t−L+1:t}`` with probability 1 − α. Unmatched filters neither resample nor select.
5. **new filters** (ℓ13–16): all ``P`` queues hold the detection as their newest pose and zeros
   (invisible) before it.

The reported pose of a matched filter is the detection, its undetected keypoints filled with the
elite-weighted mean of the particles; a coasting filter reports the mean of its particles.

``recurrence="window"`` (the paper's stateless predictor) runs the LSTM over the queues each
frame (``L`` LSTM steps per sequence from the zero state). Resampled copies of one particle and the
particles that selected the observation history hold the same queue, and queues with a common
ancestor share their older poses, so the LSTM steps once per *distinct prefix* of the distinct
queues' pointwise windows, all filters together
([`PrefixTree`][predictors.pose_lstm.prefix_tree.PrefixTree]; about 9,700 steps per frame instead of
485,000 at 10 people, P = 300, L = 10), and the FC block's first layer once per distinct queue;
the dropout mask and the Gaussian draw stay per particle. Every product sums in a fixed order, so
this gives the bits of re-running every particle's window (``share_windows=False``).
``recurrence="carried"`` keeps each particle's LSTM state
``(h, c)`` and its last visible coordinate instead, so each frame costs one LSTM step per sequence.
It differs from the window in exactly two ways: the context is not cut at ``L`` poses (the state
holds the whole history of the queue since the filter's birth, forgetting only as the LSTM
forgets), and a new filter's LSTM starts from the zero state at its first pose rather than after
``L − 1`` zero steps. Resampling copies a particle's state with its queue, and selection of the
observation history copies the filter's observation state, which is stepped with the matched
detections each frame, so both semantics share everything else.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from predictors.pose.base import centroid_fill
from predictors.pose_lstm.device import paired_oks_torch, torch_device
from predictors.pose_lstm.predictor import window_features
from track_envs.infra.compiled import njit
from track_envs.infra.registry import takes_keywords_of
from track_envs.metrics.keypoints import NUM_KEYPOINTS, oks_upper_bound, paired_oks
from track_envs.values.types import SensorSpec

#: The folder of the shipped models.
WEIGHTS = Path(__file__).resolve().parents[1] / "weights"
#: The shipped pose predictor (trained by the command in its sidecar).
DEFAULT_MODEL = WEIGHTS / "pose-lstm-walkers"


def pose_model_path(model: Any) -> Any:
    """The model file ``model`` names: ``None`` is the shipped
    [`DEFAULT_MODEL`][predictors.pose_lstm.motion.DEFAULT_MODEL]; a bare name that is no file here but a
    shipped model (``"pose-lstm-walkers-mse"``) is that shipped model; any other path, or a loaded model file,
    is returned as given."""
    if model is None:
        return DEFAULT_MODEL
    if not isinstance(model, str | Path):
        return model
    name = str(model)
    here = Path(name)
    if (
        here.name == name
        and not here.with_name(name + ".json").exists()
        and (WEIGHTS / (name + ".json")).is_file()
    ):
        return WEIGHTS / name
    return model


K = NUM_KEYPOINTS


def elite_mask(oks: NDArray[np.float64], count: int) -> NDArray[np.bool_]:
    """Footnote 2 of Okada et al. (2020): True for the ``count`` particles of highest OKS.

    Args:
        oks: (..., P, m) OKS per particle (axis −2) and detection.
        count: Number of elites per filter and detection, ``1 <= count <= P``.
    """
    P = oks.shape[-2]
    if count >= P:
        return np.ones(oks.shape, dtype=bool)
    kth = -np.partition(-oks, count - 1, axis=-2)[..., count - 1 : count, :]  # the count-th largest
    mask = oks >= kth
    # ties at the threshold: keep the first ones so exactly ``count`` are elite
    over = np.cumsum(mask, axis=-2) > count
    return mask & ~over


def resample_indices(weights: NDArray[np.float64], rng: np.random.Generator) -> NDArray[np.intp]:
    """Multinomial resampling (eq. 3) of every row of ``weights`` (k, P): (k, P) particle indices."""
    k, P = weights.shape
    if k == 0:
        return np.zeros((0, P), dtype=np.intp)
    total = weights.sum(axis=1, keepdims=True)
    w = np.where(total > 0, weights / np.where(total > 0, total, 1.0), 1.0 / P)
    cs = np.cumsum(w, axis=1)
    cs[:, -1] = 1.0
    offset = np.arange(k)[:, None]
    u = rng.random((k, P)) + offset
    idx = np.searchsorted((cs + offset).ravel(), u.ravel(), side="right").reshape(k, P) - offset * P
    return np.minimum(idx, P - 1)


@njit(cache=True, nogil=True)
def push_queues(queue: np.ndarray, pred: np.ndarray, has: np.ndarray) -> None:
    """Every queue ``queue`` (n, P, K, L, 3) float32 drops its oldest pose and takes ``(pred, has)``
    ((n, P, K, 2) px, (n, P, K)) as its newest, in place (``(x, y)`` rounded to float32, ``v`` 1 or 0)."""
    n, P, k_dim, L = queue.shape[0], queue.shape[1], queue.shape[2], queue.shape[3]
    for f in range(n):
        for p in range(P):
            for k in range(k_dim):
                q = queue[f, p, k]
                for t in range(L - 1):
                    q[t, 0], q[t, 1], q[t, 2] = q[t + 1, 0], q[t + 1, 1], q[t + 1, 2]
                q[L - 1, 0] = np.float32(pred[f, p, k, 0])
                q[L - 1, 1] = np.float32(pred[f, p, k, 1])
                q[L - 1, 2] = np.float32(1.0) if has[f, p, k] else np.float32(0.0)


@njit(cache=True, nogil=True)
def select_queues(
    queue: np.ndarray, obs: np.ndarray, ti: np.ndarray, idx: np.ndarray, own: np.ndarray
) -> None:
    """Resampling and selection (eq. 3 and 6) of the filters ``ti`` (k,), in place: particle ``p`` of
    filter ``ti[j]`` takes the queue of particle ``idx[j, p]`` if ``own[j, p]``, else the filter's
    observation queue ``obs[ti[j]]``."""
    P = queue.shape[1]
    for j in range(len(ti)):
        f = ti[j]
        source = queue[f].copy()
        for p in range(P):
            if own[j, p]:
                queue[f, p] = source[idx[j, p]]
            else:
                queue[f, p] = obs[f]


@njit(cache=True, nogil=True)
def advance_queues(
    old: np.ndarray,
    out: np.ndarray,
    pred: np.ndarray,
    has: np.ndarray,
    obs: np.ndarray,
    sel: np.ndarray,
    idx: np.ndarray,
    own: np.ndarray,
) -> None:
    """[`push_queues`][predictors.pose_lstm.motion.push_queues] and then
    [`select_queues`][predictors.pose_lstm.motion.select_queues] in one pass from ``old`` into ``out`` (both
    (n, P, K, L, 3)): particle ``p`` of filter ``f`` takes the pushed queue of particle ``src``
    (``idx[sel[f], p]`` for a selected filter, ``sel[f] >= 0``, that keeps its own history; ``p`` for the
    others) or, where ``own[sel[f], p]`` is False, the observation queue ``obs[f]``."""
    n, P, k_dim, L = old.shape[0], old.shape[1], old.shape[2], old.shape[3]
    for f in range(n):
        j = sel[f]
        for p in range(P):
            if j >= 0 and not own[j, p]:
                out[f, p] = obs[f]
                continue
            src = idx[j, p] if j >= 0 else p
            for k in range(k_dim):
                q, o = old[f, src, k], out[f, p, k]
                for t in range(L - 1):
                    o[t, 0], o[t, 1], o[t, 2] = q[t + 1, 0], q[t + 1, 1], q[t + 1, 2]
                o[L - 1, 0] = np.float32(pred[f, src, k, 0])
                o[L - 1, 1] = np.float32(pred[f, src, k, 1])
                o[L - 1, 2] = np.float32(1.0) if has[f, src, k] else np.float32(0.0)


@njit(cache=True, nogil=True)
def queue_representatives(idx: np.ndarray, own: np.ndarray, rep: np.ndarray) -> None:
    """``rep[j, p]`` (out): the first particle of row ``j`` that holds the same queue as particle
    ``p`` after selection: the same parent ``idx[j, p]`` kept (``own``), or the observation queue."""
    k, P = idx.shape
    first = np.empty(P + 1, np.intp)
    for j in range(k):
        for p in range(P + 1):
            first[p] = -1
        for p in range(P):
            key = idx[j, p] if own[j, p] else P
            if first[key] < 0:
                first[key] = p
            rep[j, p] = first[key]


@dataclass(frozen=True)
class SmcSettings:
    """The settings of the SMC pose motion ([`SmcPoseMotion`][predictors.pose_lstm.motion.SmcPoseMotion]; the
    keywords of ``pose-smc``).

    Attributes:
        particles: ``P`` particles per filter (>= 1).
        window: ``L`` poses per queue (>= 1).
        alpha: Probability α of proposing from the particle's own history (eq. 6), in [0, 1].
        elite: Elite ratio ``e`` of footnote 2, in (0, 1].
        epistemic: Dropout in the predictor's FC block at test time.
        aleatoric: The predicted (heteroscedastic) σ; ``False`` fixes σ to ``fixed_sigma``.
        fixed_sigma: σ (network units) when ``aleatoric=False`` (default: the model file's).
        recurrence: ``"window"`` (re-run the LSTM over each queue) or ``"carried"`` (LSTM state).
        share_windows: With ``"window"``, run the LSTM once per distinct window prefix (copies
            made by resampling and by selecting the observation history share their queue,
            descendants of one particle their older poses); the result is bit for bit that of
            re-running every particle's window, which ``False`` does.
        device: ``None`` (the CPU path: compiled products, the prefix tree) or a torch device
            (``"cuda"``; ``"cpu"`` to check the path without a GPU): the predictor and the
            particles' OKS in torch there ([`predictors.pose_lstm.device`][predictors.pose_lstm.device]), the
            same tracks to float tolerance (``"cuda"`` has never run on a GPU; ``"cpu"`` is tested).
    """

    particles: int = 300
    window: int = 10
    alpha: float = 0.45
    elite: float = 0.15
    epistemic: bool = True
    aleatoric: bool = True
    fixed_sigma: float | None = None
    recurrence: str = "window"
    share_windows: bool = True
    device: str | None = None

    def __post_init__(self) -> None:
        particles, window, alpha, elite = self.particles, self.window, self.alpha, self.elite
        if not (isinstance(particles, int | np.integer) and particles >= 1):
            raise ValueError(f"particles (P) must be an integer >= 1, got {particles!r}")
        if not (isinstance(window, int | np.integer) and window >= 1):
            raise ValueError(f"window (L) must be an integer >= 1, got {window!r}")
        if not (isinstance(alpha, int | float) and 0.0 <= alpha <= 1.0):
            raise ValueError(f"alpha must be in [0, 1], got {alpha!r}")
        if not (isinstance(elite, int | float) and 0.0 < elite <= 1.0):
            raise ValueError(f"elite (the elite ratio) must be in (0, 1], got {elite!r}")
        if self.fixed_sigma is not None and not (np.isfinite(self.fixed_sigma) and self.fixed_sigma >= 0):
            raise ValueError(f"fixed_sigma must be None or a number >= 0, got {self.fixed_sigma!r}")
        if self.recurrence not in ("window", "carried"):
            raise ValueError(f"recurrence must be 'window' or 'carried', got {self.recurrence!r}")
        if self.device is not None:
            torch_device(self.device)  # a name torch knows, a GPU torch sees


class SmcPoseMotion:
    """Particles of pose queues proposed by the probabilistic pose predictor (see module docstring).

    Args:
        predictor: A [`PosePredictor`][predictors.pose_lstm.predictor.PosePredictor].
        settings: The keywords of [`SmcSettings`][predictors.pose_lstm.motion.SmcSettings] (``particles``,
            ``window``, ``alpha``, …).
    """

    @takes_keywords_of(SmcSettings)
    def __init__(self, predictor: Any, **settings: Any) -> None:
        self.settings = SmcSettings(**settings)
        s = self.settings
        self.predictor = predictor
        self.P, self.L = int(s.particles), int(s.window)
        self.alpha, self.elite = float(s.alpha), float(s.elite)
        self.n_elite = max(1, math.ceil(self.elite * self.P - 1e-9))
        self.epistemic, self.aleatoric = bool(s.epistemic), bool(s.aleatoric)
        self.fixed_sigma = s.fixed_sigma
        self.recurrence = s.recurrence
        self.share_windows = bool(s.share_windows)
        self.device = s.device

    # -- episode state -------------------------------------------------------------------------
    def reset(self, spec: SensorSpec, rng: np.random.Generator) -> None:
        """No filters; ``rng`` drives dropout masks, Gaussian draws, resampling and selection."""
        self.rng = rng
        self.scale = self.predictor.scale_for(spec.region_high[1] - spec.region_low[1])
        P, L = self.P, self.L
        self.queue = np.zeros((0, P, K, L, 3), np.float32)  # particle queues z_{t-L:t-1}
        self._spare = self.queue  # the buffer the next frame's queues are written to
        self.obs = np.zeros((0, K, L, 3), np.float32)  # observation queues x_{t-L+1:t}
        self.q = np.ones((0, P))  # proposal probability of each particle's history (eq. 7)
        self.rep = np.zeros((0, P), np.intp)  # first particle of the filter with the same queue
        self.estimate = np.zeros((0, K, 2))
        self.pred = np.zeros((0, P, K, 2))
        self.has = np.zeros((0, P, K), bool)
        if self.recurrence == "carried":
            H = self.predictor.hidden
            self.h = np.zeros((0, P, K, H), np.float32)
            self.c = np.zeros((0, P, K, H), np.float32)
            self.anchor = np.zeros((0, P, K, 3), np.float32)  # last visible (x, y, 1) or zeros
            self.oh = np.zeros((0, K, H), np.float32)
            self.oc = np.zeros((0, K, H), np.float32)
            self.oanchor = np.zeros((0, K, 3), np.float32)

    def __len__(self) -> int:
        return len(self.queue)

    # -- the frame -----------------------------------------------------------------------------
    def predict(self) -> None:
        """Propose ``z_t`` for every particle of every filter (eq. 5), one batched predictor call."""
        n, P = len(self.queue), self.P
        if n == 0:
            self.pred, self.has = np.zeros((0, P, K, 2)), np.zeros((0, P, K), bool)
            return
        if self.recurrence == "window" and not self.share_windows:
            inputs, anchor, has = window_features(self.queue.reshape(-1, self.L, 3), self.scale)
            mu, sigma = self.predictor.distribution(inputs, self.rng, epistemic=self.epistemic)
        elif self.recurrence == "window":
            # the LSTM once per distinct prefix of the distinct queues (exact: the same bits as
            # every particle's window); the FC block's first layer once per distinct window; dropout and the
            # Gaussian draw per particle
            first = np.flatnonzero((self.rep == np.arange(P)).ravel())  # representatives (n·P,)
            where = np.searchsorted(first, (np.arange(n)[:, None] * P + self.rep).ravel())
            queues = self.queue.reshape(n * P, K, self.L, 3)[first]
            inputs, anchor_u, has_u = window_features(queues, self.scale)
            h, leaf = self.predictor.encode_leaves(inputs.reshape(-1, self.L, 3))
            anchor, has = anchor_u[where].reshape(-1, 2), has_u[where].reshape(-1)
            rows = leaf[(where[:, None] * K + np.arange(K)).ravel()]  # (n·P·K,) rows of h
            mu, sigma = self.predictor.head_of(h, self.rng, self.epistemic, rows=rows)
        else:
            a = self.anchor.reshape(-1, 3)
            anchor, has = a[:, :2].astype(np.float64), a[:, 2] > 0
            mu, sigma = self.predictor.head_of(self.h.reshape(-1, self.h.shape[-1]), self.rng, self.epistemic)
        z = self.predictor.draw(
            mu, sigma, anchor, self.scale, self.rng, aleatoric=self.aleatoric, fixed_sigma=self.fixed_sigma
        )
        self.pred = np.where(has[:, None], z, 0.0).reshape(n, P, K, 2)
        self.has = has.reshape(n, P, K)

    def score(self, xy: NDArray, found: NDArray, area: NDArray, floor: float = 0.0) -> NDArray[np.float64]:
        """Elite-weighted mean OKS (n, m) of each filter's particles against each detection.

        With ``floor > 0`` only the pairs that could reach it are scored (the others score 0): a
        filter's particles lie in a box per keypoint, and
        [`oks_upper_bound`][track_envs.metrics.keypoints.oks_upper_bound] of that box below ``floor`` bounds
        every particle's OKS, hence the elite mean, below it. The loop matches no pair under its
        threshold, so passing the threshold as ``floor`` changes no match and no estimate.
        """
        n, P, m = len(self.queue), self.P, len(xy)
        self._elite = np.zeros((n, P, m), dtype=bool)
        if n == 0 or m == 0:
            return np.zeros((n, m))
        if floor > 0:
            inside = self.has[..., None]
            low = np.min(np.where(inside, self.pred, np.inf), axis=1)  # (n, K, 2)
            high = np.max(np.where(inside, self.pred, -np.inf), axis=1)
            valid = np.asarray(self.has.any(axis=1), dtype=bool)
            bound = oks_upper_bound(low, high, valid, xy, found, area)
            ki, di = np.nonzero(bound >= floor * (1 - 1e-9))
        else:
            ki, di = np.divmod(np.arange(n * m), m)
        pairs = (self.pred[ki], self.has[ki], xy[di], found[di], area[di])
        if self.device is None:
            oks = paired_oks(*pairs)  # (c, P)
        else:
            oks = paired_oks_torch(*pairs, device=self.predictor.device)
        elite = elite_mask(oks[..., None], self.n_elite)[..., 0]
        self._elite[ki, :, di] = elite
        sim = np.zeros((n, m))
        sim[ki, di] = np.sum(oks * elite, axis=1) / self.n_elite
        return sim

    def update(self, ti: NDArray, di: NDArray, xy: NDArray, found: NDArray) -> None:
        """Push ``z_t`` (all filters), resample and select the matched ones (Algorithm 1, ℓ19–21).

        Filters ``ti`` (k,) matched the detections ``di`` (k,) of ``xy`` (m, 17, 2), ``found`` (m, 17).
        """
        n, P = len(self.queue), self.P
        xy, found = xy[di], found[di]
        obs_entry = np.zeros((n, K, 3), np.float32)
        obs_entry[ti, :, :2] = np.where(found[..., None], xy, 0.0)
        obs_entry[ti, :, 2] = found
        window = self.recurrence == "window"
        if not window:
            push_queues(self.queue, self.pred, self.has)  # (n, P, K, L, 3), in place
        self.obs = np.concatenate([self.obs[..., 1:, :], obs_entry[..., None, :]], axis=-2)
        self.rep = np.broadcast_to(np.arange(P), (n, P)).copy()  # each queue took its own z_t
        if self.recurrence == "carried":
            entry = np.concatenate([self.pred, self.has[..., None]], axis=-1).astype(np.float32)
            self._advance_states(entry, obs_entry)
        # estimates: particle means (coasting), the detection + elite means (matched)
        has_any = np.asarray(self.has.any(axis=1), dtype=bool)
        mean = np.sum(self.pred, axis=1) / np.maximum(self.has.sum(axis=1), 1)[..., None]
        estimate = centroid_fill(mean, has_any) if n else np.zeros((0, K, 2))
        if len(ti):
            elite = self._elite[ti, :, di].astype(np.float64)  # (k, P) elite weights for the match
            w_el = elite[..., None] * self.has[ti]  # (k, P, K)
            emean = (
                np.sum(self.pred[ti] * w_el[..., None], axis=1) / np.maximum(w_el.sum(axis=1), 1)[..., None]
            )
            ok = found | (w_el.sum(axis=1) > 0)
            estimate[ti] = centroid_fill(np.where(found[..., None], xy, emean), ok)
            idx, own = self._resample_and_select(ti, elite)
        else:
            idx, own = np.zeros((0, P), np.intp), np.zeros((0, P), bool)
        if window:  # the push, the resampling and the selection in one pass into the spare buffer
            sel = np.full(n, -1, np.intp)
            sel[ti] = np.arange(len(ti))
            spare = self._spare if self._spare.shape == self.queue.shape else np.empty_like(self.queue)
            advance_queues(self.queue, spare, self.pred, self.has, self.obs, sel, idx, own)
            self._spare, self.queue = self.queue, spare
        self.estimate = estimate

    def _resample_and_select(self, ti: NDArray, elite: NDArray[np.float64]) -> tuple[NDArray, NDArray]:
        """The draws of resampling and selection of the matched filters ``ti``: ``(idx, own)`` (k, P);
        the queues move in [`update`][predictors.pose_lstm.motion.SmcPoseMotion.update] (window) or here, in
        place (carried)."""
        weights = elite / self.q[ti]  # eq. (7) with the elite weights of footnote 2
        idx = resample_indices(weights, self.rng)  # (k, P)
        rows = ti[:, None]
        own = self.rng.random(idx.shape) < self.alpha  # eq. (6)
        rep = np.empty(idx.shape, np.intp)
        queue_representatives(idx, own, rep)
        self.q[ti] = np.where(own, self.alpha, 1.0 - self.alpha)
        self.rep[ti] = rep
        if self.recurrence == "carried":
            select_queues(self.queue, self.obs, ti, idx, own)  # in place
            for name, oname in (("h", "oh"), ("c", "oc"), ("anchor", "oanchor")):
                arr, oarr = getattr(self, name), getattr(self, oname)
                arr[ti] = np.where(own[..., None, None], arr[rows, idx], oarr[ti][:, None])
        return idx, own

    def birth(self, xy: NDArray, found: NDArray) -> None:
        """New filters: every queue holds the detection as newest pose, zeros before (ℓ15–16)."""
        k, P, L = len(xy), self.P, self.L
        if k == 0:
            return  # nothing to append (and no copy of every queue)
        first = np.zeros((k, K, 3), np.float32)
        first[..., :2] = np.where(found[..., None], xy, 0.0)
        first[..., 2] = found
        obs = np.zeros((k, K, L, 3), np.float32)
        obs[..., -1, :] = first
        self.obs = np.concatenate([self.obs, obs])
        self.queue = np.concatenate([self.queue, np.broadcast_to(obs[:, None], (k, P, K, L, 3))])
        self.q = np.concatenate([self.q, np.ones((k, P))])
        self.rep = np.concatenate([self.rep, np.zeros((k, P), np.intp)])  # all queues equal
        self.estimate = np.concatenate([self.estimate, centroid_fill(xy, found)])
        if self.recurrence == "carried":
            h, c, anchor = self._start_states(first)
            self.oh, self.oc, self.oanchor = (
                np.concatenate([a, b]) for a, b in ((self.oh, h), (self.oc, c), (self.oanchor, anchor))
            )
            rep = lambda a: np.broadcast_to(a[:, None], (k, P, *a.shape[1:]))  # noqa: E731
            self.h = np.concatenate([self.h, rep(h)])
            self.c = np.concatenate([self.c, rep(c)])
            self.anchor = np.concatenate([self.anchor, rep(anchor)])

    def keep(self, alive: NDArray[np.bool_]) -> None:
        """Deactivate the filters whose lifetime fell below 0."""
        if np.all(alive):
            return  # every filter kept (and no copy of every queue)
        self.queue, self.obs, self.q, self.estimate = (
            self.queue[alive],
            self.obs[alive],
            self.q[alive],
            self.estimate[alive],
        )
        self.rep = self.rep[alive]
        if self.recurrence == "carried":
            for name in ("h", "c", "anchor", "oh", "oc", "oanchor"):
                setattr(self, name, getattr(self, name)[alive])

    def poses(self) -> NDArray[np.float64]:
        """(n, 17, 2) reported poses."""
        return self.estimate

    # -- carried LSTM state --------------------------------------------------------------------
    def _step_inputs(self, prev: NDArray, entry: NDArray) -> NDArray[np.float32]:
        """``(Δx/s, Δy/s, v)`` of a new queue entry after ``prev`` (both (..., 3))."""
        both = (prev[..., 2] > 0) & (entry[..., 2] > 0)
        d = np.where(both[..., None], (entry[..., :2] - prev[..., :2]) / self.scale, 0.0)
        return np.concatenate([d, entry[..., 2:3]], axis=-1).astype(np.float32)

    def _start_states(self, first: NDArray) -> tuple[NDArray, NDArray, NDArray]:
        x = self._step_inputs(first, first).reshape(-1, 3)  # Δ = 0 at the first pose
        h, c = self.predictor.step(x, None)
        H = self.predictor.hidden
        anchor = np.where(first[..., 2:3] > 0, first, 0.0).astype(np.float32)
        return h.reshape(*first.shape[:-1], H), c.reshape(*first.shape[:-1], H), anchor

    def _advance_states(self, entry: NDArray, obs_entry: NDArray) -> None:
        n, P, H = len(self.queue), self.P, self.predictor.hidden
        if n == 0:
            return
        prev = self.queue[..., -2, :] if self.L >= 2 else self.anchor  # the entry before the new one
        x = self._step_inputs(prev, entry).reshape(-1, 3)
        h, c = self.predictor.step(x, (self.h.reshape(-1, H), self.c.reshape(-1, H)))
        self.h, self.c = h.reshape(n, P, K, H), c.reshape(n, P, K, H)
        self.anchor = np.where(entry[..., 2:3] > 0, entry, self.anchor)
        oprev = self.obs[..., -2, :] if self.L >= 2 else self.oanchor
        ox = self._step_inputs(oprev, obs_entry).reshape(-1, 3)
        oh, oc = self.predictor.step(ox, (self.oh.reshape(-1, H), self.oc.reshape(-1, H)))
        self.oh, self.oc = oh.reshape(n, K, H), oc.reshape(n, K, H)
        self.oanchor = np.where(obs_entry[..., 2:3] > 0, obs_entry, self.oanchor)
