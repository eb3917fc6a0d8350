"""jpda with and without its merge model on the pair scenes of
[`track_envs.streams.merge_scenes`][track_envs.streams.merge_scenes].

For every scene and seed the same stream is tracked by jpda (kf-ca) in each arm of `ARMS`
(without the merge model, with it keeping the members' predicted offset as before, and with the
rigid pair), and scored against truth with the merged ids: e1 (share of tracks holding detections of more
than one particle), e2, ID switches (CLEAR MOT, match distance 2 mm) and HOTA (zero similarity at
2 mm). Prints a markdown table of mean ± std over the seeds and writes ``--csv`` if given.

``--figure PATH`` draws one encounter (``--event-scene``, ``--event-seed``, ``--event``) as tracked
in each arm: the true paths, the detections (blobs ringed) and every track near the pair.

Usage::

    python benchmarks/merge_mechanism.py --seeds 5 [--events 24] [--csv out.csv] [--agent-kwargs k=v,...]
    python benchmarks/merge_mechanism.py --seeds 0 --figure docs/figures/merge_mechanism.png
"""

from __future__ import annotations

import argparse
import csv
import sys
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agents import make_agent
from track_envs.io import atomic_write, save_figure
from track_envs.metrics import AssociationErrors, ClearMot
from track_envs.metrics.base import Metric
from track_envs.metrics.hota_stream import Hota
from track_envs.streams.merge_scenes import SCENES, MergeScene, merge_scene

THRESHOLD = 0.002  # m: CLEAR MOT's match distance and HOTA's zero-similarity distance
METRICS = ("e1", "e2", "id_switches", "hota")
#: jpda's settings per arm: without the merge model, with it as before (the members of a blob
#: keep their predicted offset) and with the rigid pair (their last estimates' offset)
ARMS: dict[str, dict[str, Any]] = {
    "off": {"merge_model": False},
    "on, predicted offset": {"merge_model": True, "rigid_merge": False},
    "on, rigid pair": {"merge_model": True, "rigid_merge": True},
}


def score(agent: Any, scene: MergeScene, *, seed: int = 0) -> dict[str, float]:
    """Run ``agent`` over ``scene`` and return e1, e2, ID switches and HOTA (merged ids)."""
    metrics: list[Metric] = [AssociationErrors(), ClearMot(threshold=THRESHOLD), Hota(threshold=THRESHOLD)]
    agent.reset(scene.spec, seed=seed)
    for t in range(len(scene)):
        report = agent.act(scene.observation(t))
        truth = scene.truth(t)
        for metric in metrics:
            metric.update(truth, scene.detection_ids[t], report)
    out: dict[str, float] = {}
    for metric in metrics:
        out.update({k: float(v) for k, v in metric.compute().items()})
    return {k: out[k] for k in METRICS}


def run(scenes: tuple[str, ...], seeds: int, events: int, kwargs: dict[str, Any]) -> list[dict[str, Any]]:
    """One row per scene, seed and merge model."""
    rows = []
    for name in scenes:
        for seed in range(seeds):
            scene = merge_scene(name, np.random.default_rng(seed), n_events=events)
            for arm, extra in ARMS.items():
                agent = make_agent("jpda", predictor="kf-ca", **(extra | kwargs))
                rows.append({"scene": name, "seed": seed, "arm": arm} | score(agent, scene, seed=seed))
    return rows


def table(rows: list[dict[str, Any]]) -> str:
    """Markdown: per scene and arm, mean ± std over the seeds of each metric."""
    lines = ["| scene | jpda merge model | e1 | e2 | ID switches | HOTA |", "|---|---|---|---|---|---|"]
    for name in dict.fromkeys(r["scene"] for r in rows):
        for arm in dict.fromkeys(r["arm"] for r in rows):
            cells = []
            for metric in METRICS:
                v = np.array([r[metric] for r in rows if r["scene"] == name and r["arm"] == arm])
                fmt = "{:.1f} ± {:.1f}" if metric == "id_switches" else "{:.3f} ± {:.3f}"
                cells.append(fmt.format(v.mean(), v.std(ddof=1) if len(v) > 1 else 0.0))
            lines.append(f"| {name} | {arm} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def trace(agent: Any, scene: MergeScene, frames: range, near: NDArray[np.int64]) -> dict[int, NDArray]:
    """Every reported track's positions over ``frames`` while within 8 mm of a particle ``near``:
    track id -> (k, 3) rows ``(frame, x, y)``."""
    agent.reset(scene.spec, seed=0)
    paths: dict[int, list[tuple[float, float, float]]] = {}
    for t in range(frames.stop):
        report = agent.act(scene.observation(t))
        if t < frames.start:
            continue
        live = np.asarray(report["mask"], bool) if "mask" in report else np.ones(len(report["ids"]), bool)
        pos = np.asarray(report["positions"])[live]
        ids = np.asarray(report["ids"])[live]
        d = np.linalg.norm(pos[:, None, :] - scene.positions[t, near][None], axis=2).min(axis=1)
        for k in np.flatnonzero(d < 0.008):
            paths.setdefault(int(ids[k]), []).append((t, *pos[k]))
    return {k: np.array(v) for k, v in paths.items()}


def figure(path: str, name: str, seed: int, event: int, events: int) -> None:
    """One encounter in each arm (module docstring), x along the belt, in mm."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    scene = merge_scene(name, np.random.default_rng(seed), n_events=events)
    a, b = scene.involved[event]
    meet = int(scene.meet_frames[event])
    second = scene.detection_ids[:, :, 1]
    touching = np.flatnonzero(np.any((second == a) | (second == b), axis=1))
    lo = int(touching.min()) - 8 if len(touching) else meet - 12
    hi = int(touching.max()) + 10 if len(touching) else meet + 12
    frames = range(max(lo, 0), min(hi, len(scene)))
    fig, axes = plt.subplots(len(ARMS), 1, figsize=(9, 2.6 * len(ARMS)), sharex=True, sharey=True)
    f = np.arange(frames.start, frames.stop)
    for ax, (arm, kwargs) in zip(axes, ARMS.items(), strict=True):
        for p, colour in ((a, "0.55"), (b, "0.8")):
            ax.plot(*(scene.positions[f, p].T * 1e3), "-", color=colour, lw=6, alpha=0.6, zorder=0)
        for t in f:
            rows = np.flatnonzero(scene.mask[t])
            ids = scene.detection_ids[t, rows]
            mine = np.isin(ids[:, 0], (a, b))
            z = scene.detections[t, rows[mine]] * 1e3
            blob = ids[mine, 1] >= 0
            ax.plot(z[~blob, 0], z[~blob, 1], "k.", ms=3, zorder=2)
            ax.plot(z[blob, 0], z[blob, 1], "o", mfc="none", mec="k", ms=6, zorder=2)
        agent = make_agent("jpda", predictor="kf-ca", **kwargs)
        for k, (tid, rows) in enumerate(sorted(trace(agent, scene, frames, np.array([a, b])).items())):
            ax.plot(rows[:, 1] * 1e3, rows[:, 2] * 1e3, "-", lw=1.4, color=f"C{k % 10}", label=f"track {tid}")
        ax.set_title(f"jpda, merge model {arm}", fontsize=9)
        ax.set_ylabel("y (mm)")
        ax.legend(fontsize=7, loc="upper left", ncol=4)
    axes[-1].set_xlabel("x along the belt (mm)")
    fig.suptitle(
        f"scene {name!r}, seed {seed}, encounter {event}: true paths (grey: particle {a} dark, {b} light), "
        "detections (dots; blobs ringed)",
        fontsize=9,
    )
    fig.tight_layout()
    try:
        save_figure(fig, path, dpi=110)
    finally:
        plt.close(fig)


def _kwargs(text: str) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for item in filter(None, text.split(",")):
        k, v = item.split("=")
        out[k] = {"true": True, "false": False}.get(v.lower())
        if out[k] is None:
            out[k] = float(v)
    return out


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seeds", type=int, default=5)
    p.add_argument("--events", type=int, default=24)
    p.add_argument("--scenes", default=",".join(SCENES))
    p.add_argument("--csv")
    p.add_argument("--agent-kwargs", default="")
    p.add_argument("--figure")
    p.add_argument("--event-scene", default="touching")
    p.add_argument("--event-seed", type=int, default=0)
    p.add_argument("--event", type=int, default=2)
    a = p.parse_args(argv)
    if a.figure:
        figure(a.figure, a.event_scene, a.event_seed, a.event, a.events)
    if a.seeds < 1:
        return 0
    rows = run(tuple(a.scenes.split(",")), a.seeds, a.events, _kwargs(a.agent_kwargs))
    if a.csv:
        with atomic_write(a.csv, newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)
    print(table(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
