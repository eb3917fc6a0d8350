"""A plain ``pip install .`` (no extras) tracks: the envs, gnn with every Kalman predictor and the
shipped belt LSTMs run in numpy, without torch; training and pose-smc say which extra they need."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

#: Makes ``import torch`` fail as it does where torch is not installed (a ``sys.modules["torch"] =
#: None`` entry would break scipy, which probes ``sys.modules`` for torch arrays).
BLOCK_TORCH = """
import importlib.abc, sys

class _NoTorch(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path=None, target=None):
        if name == "torch" or name.startswith("torch."):
            raise ModuleNotFoundError(f"No module named {name!r}", name=name)
        return None

sys.meta_path.insert(0, _NoTorch())
"""

SCRIPT = """
import gymnasium as gym

import track_envs  # noqa: F401
from agents import make_agent
from track_envs.wrappers import TrackingMetrics

for predictor in ("kf-cv", "kf-ca", "random-walk", "lstm", "nll-lstm", "mc-lstm"):
    env = TrackingMetrics(gym.make("BeltSorter-v0", max_episode_steps=3))
    agent = make_agent("gnn", predictor=predictor)
    obs, info = env.reset(seed=0)
    agent.reset(env.get_wrapper_attr("sensor_spec"), seed=0)
    done = False
    while not done:
        obs, reward, terminated, truncated, info = env.step(agent.act(obs))
        done = terminated or truncated
    assert "mota" in info["episode_metrics"], predictor
    print(predictor, "ok")
assert not [m for m in sys.modules if m == "torch" or m.startswith("torch.")]

try:
    make_agent("pose-smc")
except ModuleNotFoundError as exc:
    print(exc, file=sys.stderr)
else:
    raise AssertionError("pose-smc ran without torch")

from track_apps.cli import main

assert main(["train", "lstm", "--env", "SineTarget-v0", "--episodes", "1", "--out", "unused"]) == 2
"""


def run(code: str, tmp_path: Path) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "PYTHONPATH": str(ROOT), "MPLBACKEND": "Agg", "OMP_NUM_THREADS": "1"}
    return subprocess.run(
        [sys.executable, "-c", code], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600
    )


def test_gnn_with_kalman_filters_and_the_shipped_lstms_runs_without_torch(tmp_path):
    result = run(BLOCK_TORCH + textwrap.dedent(SCRIPT), tmp_path)
    assert result.returncode == 0, result.stderr[-3000:]
    assert result.stdout.split() == [
        word for p in ("kf-cv", "kf-ca", "random-walk", "lstm", "nll-lstm", "mc-lstm") for word in (p, "ok")
    ]
    assert 'training needs torch: pip install "track-envs[torch]"' in result.stderr
    assert 'pose-smc needs torch (its pose predictor): pip install "track-envs[torch]"' in result.stderr


def test_safetensors_is_a_base_dependency():
    import tomllib

    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    assert any(d.startswith("safetensors") for d in project["dependencies"])
    for extra, deps in project["optional-dependencies"].items():
        assert not any(d.startswith("safetensors") for d in deps), extra
