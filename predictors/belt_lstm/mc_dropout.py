"""Monte Carlo dropout inference that computes each distinct sample once (exact).

With variational dropout (one mask per track and sample, fixed over time) the ``T`` Monte Carlo
passes of a track differ only where a mask drops a unit. At the small rates the belt models use
(0.2%: Pollithy et al. 2020, Sec. IV-C) most samples drop nothing at all, and the masks of one
layer do not affect the layers below it. So each sample falls in one of four groups, decided once
per track when its masks are drawn (``s = 1/(1 − p)`` is the value of a kept unit):

* **clean**: no unit dropped anywhere. All clean samples are one computation, the network with
  every mask equal to ``s``; the track keeps their count.
* **head-only**: only the head's input mask drops. Both LSTM layers equal the clean ones; only
  the head ``(h₂ ⊙ m_head) W + b`` is computed per sample.
* **layer-2**: layer 1 is clean, layer 2's input or state mask drops. Layer 1 is the clean one;
  layer 2 and the head run per sample, carrying their own layer-2 state.
* **layer-1**: layer 1's input or state mask drops: everything runs per sample.

At p = 0.2% with 64/32 units this computes layer 1 for ≈13% of the samples and layer 2 for ≈28%
instead of all of them, with the same result as the plain ``T``-sample computation (tested to
1e-12 in float64). The per-track predictive mean and covariance (Pollithy et al. 2020, eqs.
(3)–(4)) are accumulated from the groups with their counts.

Sample rows are kept per track in padded blocks (``(n, K, ...)`` with a validity mask), so the
state has tracks on its first axis like every predictor state;
[`MCState.concat`][predictors.belt_lstm.mc_dropout.MCState.concat] pads blocks of different ``K``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, fields
from typing import Any, Self

import numpy as np
from numpy.typing import NDArray

from predictors.base import BatchState

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]


@dataclass(frozen=True)
class MCState(BatchState):
    """Per-track state of grouped MC dropout (first axis: tracks).

    Attributes:
        h1, c1, h2, c2: The clean samples' recurrent state (n, H).
        n_clean: Number of clean samples per track (n,).
        a_mask, a_valid, a_h1, a_c1, a_h2, a_c2: layer-1 group: masks (n, KA, W), validity
            (n, KA), own states.
        b_mask, b_valid, b_h2, b_c2: layer-2 group: layer-2 and head masks (n, KB, H1 + 2 H2),
            validity, own layer-2 states.
        c_mask, c_valid: head-only group: head masks (n, KC, H2), validity.
        mean, cov: predictive mean (n, D) and sample covariance (n, D, D) of the head outputs.
        z, z_cov, z_prev: as in
            [`predictors.belt_lstm.predictor.LSTMTrackState`][predictors.belt_lstm.predictor.LSTMTrackState].
    """

    h1: FloatArray
    c1: FloatArray
    h2: FloatArray
    c2: FloatArray
    n_clean: NDArray[np.int64]
    a_mask: FloatArray
    a_valid: BoolArray
    a_h1: FloatArray
    a_c1: FloatArray
    a_h2: FloatArray
    a_c2: FloatArray
    b_mask: FloatArray
    b_valid: BoolArray
    b_h2: FloatArray
    b_c2: FloatArray
    c_mask: FloatArray
    c_valid: BoolArray
    mean: FloatArray
    cov: FloatArray
    z: FloatArray
    z_cov: FloatArray
    z_prev: FloatArray

    @classmethod
    def concat(cls, states: Sequence[Self]) -> Self:
        """Append tracks, padding the sample blocks to the largest ``K`` of each group."""
        if not states:
            raise ValueError(f"{cls.__name__}.concat needs at least one state")
        out = {}
        for f in fields(cls):
            parts = [getattr(s, f.name) for s in states]
            if f.name[:2] in ("a_", "b_", "c_"):
                k = max(p.shape[1] for p in parts)
                parts = [_pad_axis1(p, k) for p in parts]
            out[f.name] = np.concatenate(parts)
        return cls(**out)


def _pad_axis1(a: np.ndarray, k: int) -> np.ndarray:
    if a.shape[1] == k:
        return a
    pad = np.zeros((a.shape[0], k - a.shape[1], *a.shape[2:]), dtype=a.dtype)
    return np.concatenate([a, pad], axis=1)


def _block(selected: BoolArray, values: np.ndarray, dtype: type = np.float64) -> tuple[np.ndarray, BoolArray]:
    """The samples ``selected`` (n, T) of each track, in order, as a padded (n, K, W) block of
    their ``values`` (n, T, W) and its validity mask (n, K); K is the largest count."""
    n = selected.shape[0]
    counts = selected.sum(axis=1)
    k = int(counts.max()) if n else 0
    first = np.argsort(~selected, axis=1, kind="stable")[:, :k]  # selected samples first, in order
    valid = np.arange(k)[None, :] < counts[:, None]
    block: np.ndarray = np.take_along_axis(values, first[..., None], axis=1).astype(dtype)
    block[~valid] = 0.0
    return block, valid


class GroupedMC:
    """MC-dropout inference of [`LSTMWeights`][predictors.belt_lstm.inference.LSTMWeights] by sample groups.

    Args:
        net: The network weights ([`LSTMWeights`][predictors.belt_lstm.inference.LSTMWeights] or its float32
            twin [`FastLSTMWeights`][predictors.belt_lstm.inference.FastLSTMWeights]).
        widths: Mask widths ``(In, H1, H1, H2, H2)``.
        keep: Keep probability ``1 − p``.
    """

    def __init__(self, net: Any, widths: tuple[int, ...], keep: float):
        self.net, self.widths, self.keep = net, widths, keep
        self.dtype = net.head_w.dtype.type  # float32 for the fast path, float64 for the reference
        self.cuts = np.cumsum(widths)[:-1]

    def start(self, x: FloatArray, masks: FloatArray) -> MCState:
        """Group the masks (n, T, ΣW) of new tracks and run their first step on inputs ``x`` (n, In)."""
        n = masks.shape[0]
        dropped = masks == 0.0
        w_in, w_h1, w_x2, w_h2, _ = self.widths
        l1 = dropped[..., : w_in + w_h1].any(axis=-1)
        l2 = ~l1 & dropped[..., w_in + w_h1 : w_in + w_h1 + w_x2 + w_h2].any(axis=-1)
        head = ~l1 & ~l2 & dropped[..., w_in + w_h1 + w_x2 + w_h2 :].any(axis=-1)
        clean = ~(l1 | l2 | head)
        dt = self.dtype
        a_mask, a_valid = _block(l1, masks, dt)
        b_mask, b_valid = _block(l2, masks[..., w_in + w_h1 :], dt)
        c_mask, c_valid = _block(head, masks[..., w_in + w_h1 + w_x2 + w_h2 :], dt)
        h1, c1, h2, c2 = self.net.zero_state(n)
        ka, kb = a_mask.shape[1], b_mask.shape[1]
        z1, z2 = np.zeros((n, ka, w_h1), dt), np.zeros((n, ka, w_h2), dt)
        zb = np.zeros((n, kb, w_h2), dt)
        state = MCState(
            h1, c1, h2, c2, clean.sum(axis=1).astype(np.int64),
            a_mask, a_valid, z1, z1.copy(), z2, z2.copy(),
            b_mask, b_valid, zb, zb.copy(),
            c_mask, c_valid,
            np.zeros((n, 0)), np.zeros((n, 0, 0)), np.zeros((n, 0)), np.zeros((n, 0, 0)), np.zeros((n, 0)),
        )  # fmt: skip
        return self.step(x, state)

    def step(self, x: FloatArray, s: MCState) -> MCState:
        """One step of every sample group on inputs ``x`` (n, In); the new state with its moments."""
        net, sc = self.net, 1.0 / self.keep
        _, _, w_x2, w_h2, _ = self.widths
        n = len(x)
        # clean samples: every mask equals s
        h1, c1 = net.layer1.step(x * sc, s.h1 * sc, s.c1)
        h2, c2 = net.layer2.step(h1 * sc, s.h2 * sc, s.c2)
        y_clean = (h2 * sc) @ net.head_w + net.head_b  # (n, out)
        # moments of the deviations from the clean output (exact, and no cancellation: most
        # samples are clean and contribute zero)
        out = y_clean.shape[1]
        total = np.zeros((n, out))
        second = np.zeros((n, out, out))
        a_h1, a_c1, a_h2, a_c2 = s.a_h1.copy(), s.a_c1.copy(), s.a_h2.copy(), s.a_c2.copy()
        b_h2, b_c2 = s.b_h2.copy(), s.b_c2.copy()
        # layer-1 group: everything per sample
        ra, ka = np.nonzero(s.a_valid)
        if len(ra):
            m = s.a_mask[ra, ka]
            mx, mh1, mx2, mh2, mhead = np.split(m, self.cuts, axis=1)
            nh1, nc1 = net.layer1.step(x[ra] * mx, s.a_h1[ra, ka] * mh1, s.a_c1[ra, ka])
            nh2, nc2 = net.layer2.step(nh1 * mx2, s.a_h2[ra, ka] * mh2, s.a_c2[ra, ka])
            y = (nh2 * mhead) @ net.head_w + net.head_b
            a_h1[ra, ka], a_c1[ra, ka], a_h2[ra, ka], a_c2[ra, ka] = nh1, nc1, nh2, nc2
            total, second = _accumulate(total, second, ra, y - y_clean[ra])
        # layer-2 group: the clean layer 1, own layer 2
        rb, kb = np.nonzero(s.b_valid)
        if len(rb):
            m = s.b_mask[rb, kb]
            mx2, mh2, mhead = m[:, :w_x2], m[:, w_x2 : w_x2 + w_h2], m[:, w_x2 + w_h2 :]
            nh2, nc2 = net.layer2.step(h1[rb] * mx2, s.b_h2[rb, kb] * mh2, s.b_c2[rb, kb])
            y = (nh2 * mhead) @ net.head_w + net.head_b
            b_h2[rb, kb], b_c2[rb, kb] = nh2, nc2
            total, second = _accumulate(total, second, rb, y - y_clean[rb])
        # head-only group: the clean layers, own head mask
        rc, kc = np.nonzero(s.c_valid)
        if len(rc):
            y = (h2[rc] * s.c_mask[rc, kc]) @ net.head_w + net.head_b
            total, second = _accumulate(total, second, rc, y - y_clean[rc])
        T = s.n_clean + s.a_valid.sum(axis=1) + s.b_valid.sum(axis=1) + s.c_valid.sum(axis=1)
        shift = total / T[:, None]
        mean = y_clean + shift
        cov = second / T[:, None, None] - np.einsum("nd,ne->nde", shift, shift)
        return MCState(
            h1, c1, h2, c2, s.n_clean,
            s.a_mask, s.a_valid, a_h1, a_c1, a_h2, a_c2,
            s.b_mask, s.b_valid, b_h2, b_c2,
            s.c_mask, s.c_valid,
            mean, cov, s.z, s.z_cov, s.z_prev,
        )  # fmt: skip


def _accumulate(
    total: FloatArray, second: FloatArray, rows: np.ndarray, y: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Add sample deviations ``y`` (k, out) to their tracks' sums of y and y yᵀ (in place)."""
    np.add.at(total, rows, y)
    np.add.at(second, rows, np.einsum("kd,ke->kde", y, y))
    return total, second
