"""Every example script runs (with small budgets)."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def load(name: str):
    spec = importlib.util.spec_from_file_location(name, EXAMPLES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module  # dataclasses look their module up there
    spec.loader.exec_module(module)
    return module


def test_belt_sorter_episode_prints_metrics_and_writes_a_png(tmp_path, capsys):
    png = tmp_path / "frame.png"
    summary = load("belt_sorter_episode").main(["--steps", "40", "--png", str(png)])
    assert summary["frames"] == 40
    assert summary["mean particles in window"] > 10
    assert summary["e_mean"] < 0.05 and summary["MOTA"] > 0.9
    assert png.stat().st_size > 1000
    assert "mean GOSPA" in capsys.readouterr().out


def test_pf_paper_figures_quick_runs_every_experiment_with_both_filters(tmp_path, capsys):
    learned = "lstm"
    out = load("pf_paper_figures").main(["--quick", "--runs", "8", "--out", str(tmp_path)])
    assert [Path(f).name for f in out["files"]] == [
        "fig3_tracks.png",
        "fig4_error_grid.png",
        "fig5_error_sigma_n.png",
        "fig6_occlusion_example.png",
        "fig7_occlusion.png",
        "fig8_piecewise.png",
    ]
    for f in out["files"]:
        assert Path(f).stat().st_size > 1000
    for key in ("fig4", "fig5"):
        assert set(out[f"{key}_error"]) == {"brownian", learned}
        assert out[f"{key}_gain"].shape == (2, 2) and np.isfinite(out[f"{key}_gain"]).all()
    brownian = out["fig4_error"]["brownian"]
    # p_detect = 1 tracks better than p_detect = 0.3 at the same σ_p
    assert np.all(brownian[1] < brownian[0])
    # the LSTM-PF gains > 60% over the Brownian PF at low p_d and low σ_p (84-89% over seeds 0-3), and
    # is better in every cell of the N × σ_p grid (14% in its worst cell over those seeds)
    assert out["fig4_gain"][0, 0] > 60, out["fig4_gain"]
    assert np.all(out["fig5_gain"] > 0), out["fig5_gain"]
    assert out["fig7_lost"]["brownian"].shape == (2,)
    tables = (tmp_path / "tables.md").read_text()
    assert tables.count("| claim | paper | ours |") == 1 and len(out["claims"]) >= 10
    assert "Exp. 5 / Fig. 8" in capsys.readouterr().out


def test_track_any_env_runs_every_family(tmp_path, capsys):
    example = load("track_any_env")
    poses = example.main(["--env", "KeypointWalkers-v0", "--steps", "30", "--png", str(tmp_path / "p.png")])
    assert 0 < poses["mota"] <= 1 and (tmp_path / "p.png").stat().st_size > 1000
    single = example.main(
        ["--env", "SineTarget-v0", "--agent", "pf", "--steps", "50", "--kwargs", "p_detect=1.0"]
    )
    assert single["mean_error"] < 1.0
    belt = example.main(["--env", "BeltReplay-v0", "--predictor", "kf-cv", "--steps", "40"])
    assert belt["e2"] < 0.05
    assert "SineTarget-v0 + pf" in capsys.readouterr().out


def test_gate_tuning_trace_plays_the_policies_on_one_episode(tmp_path, capsys):
    import gymnasium as gym

    from track_apps.tuning import FixedPolicy
    from track_apps.tuning.evaluate import episode_errors
    from track_apps.tuning.informed import SensorTable

    states = {"noise_std": (1e-4, 1e-3), "p_detect": (0.9,), "clutter_rate": (0.0,)}
    table = SensorTable(states, [{"p_gate": 0.9}], np.ones((2, 1, 1, 1)), (0,), 1).save(tmp_path / "t.json")
    png = tmp_path / "trace.png"
    out = load("gate_tuning_trace").main(["--steps", "4", "--table", str(table), "--png", str(png)])
    assert set(out["errors"]) == {"PPO", "best fixed", "sensor-informed"}
    assert png.stat().st_size > 1000
    fixed = out["traces"]["best fixed"]
    assert len(fixed["errors"]) == 4 and np.all(np.diff(fixed["errors"]) >= 0)
    np.testing.assert_allclose(out["traces"]["sensor-informed"]["p_gate"], 0.9, rtol=1e-5)
    env = gym.make("GateTuning-v0", episode_steps=4)
    expected = episode_errors(
        env, FixedPolicy({"p_gate": 0.7, "recovery_inflation": 1.0, "noise_scale": 32.0}), 10**9
    )
    assert out["errors"]["best fixed"] == expected["errors"]
    assert "association errors" in capsys.readouterr().out


def test_extend_env_registers_a_contract_conforming_env_that_gnn_tracks(capsys):
    metrics = load("extend_env").main(["--steps", "40"])
    assert 0.5 < metrics["mota"] <= 1 and metrics["idf1"] > 0.7
    assert "CirclingTargets-v0: 40 frames" in capsys.readouterr().out


def test_extend_env_rejects_a_bad_argument_by_name():
    module = load("extend_env")
    with pytest.raises(ValueError, match=r"num_targets must be in 1\.\.32, got 0"):
        module.CirclingTargetsEnv(num_targets=0)


def test_extend_metric_is_scored_beside_the_default_metrics():
    metrics = load("extend_metric").main(["--steps", "60"])
    assert 0.5 < metrics["coverage"] < 1 and metrics["rmse"] > 0  # SineTarget-v0's own metrics too


def test_extend_metric_coverage_closed_form():
    coverage = load("extend_metric").Coverage(radius=1.0)
    truth = {"positions": np.array([[0.0, 0.0], [5.0, 0.0], [9.0, 9.0]]), "visible": np.array([1, 1, 0])}
    near = {"positions": np.array([[0.5, 0.0], [5.0, 0.9], [0.0, 0.0]]), "mask": np.array([1, 1, 0])}
    far = {"positions": np.array([[0.5, 0.0], [7.0, 0.0]]), "mask": np.array([1, 1])}
    coverage.update(truth, np.array([-1]), near)  # both visible targets within 1
    coverage.update(truth, np.array([-1]), far)  # the second is 2 away
    coverage.update({"positions": np.zeros((1, 2)), "visible": np.array([0])}, np.array([-1]), far)
    assert coverage.compute() == {"coverage": 2 / 3}


# -- the worked examples of docs/architecture.md#extending: a predictor, a learned predictor, an agent


def sine_spec(**changes):
    import dataclasses

    import gymnasium as gym

    import track_envs  # noqa: F401

    return dataclasses.replace(gym.make("SineTarget-v0").unwrapped.sensor_spec, **changes)


def track_episode(agent, steps, **env_kwargs):
    """The episode metrics of ``agent`` on ``steps`` frames of SineTarget-v0 (seed 0)."""
    import gymnasium as gym

    from agents import run_episode
    from track_envs.wrappers import TrackingMetrics

    env = TrackingMetrics(gym.make("SineTarget-v0", max_episode_steps=steps, **env_kwargs))
    return run_episode(env, agent, seed=0).metrics


def test_extend_predictor_tracks_in_gnn_and_gnn_uses_its_declared_capability(scoped_registries, capsys):
    from agents import make_agent

    example = load("extend_predictor")
    metrics = example.main(["--steps", "150"])  # check_predictor runs inside
    assert metrics["lost"] == 0 and metrics["frames_without_estimate"] == 0
    assert 0.05 < metrics["mean_error"] < 0.25  # σ_n = 0.1 per axis, clutter 0.5 per frame
    assert "SineTarget-v0 + gnn(alpha-beta), 150 frames" in capsys.readouterr().out

    class Counting(example.AlphaBetaPredictor):
        """Counts the starts, and those with a velocity prior."""

        def __init__(self):
            super().__init__()
            self.starts = self.with_prior = 0

        def start(self, z, velocity=None, velocity_cov=None):
            self.starts += 1
            self.with_prior += velocity is not None
            return super().start(z, velocity, velocity_cov)

    class CoreOnly(Counting):
        capabilities = frozenset()

    declared, core = Counting(), CoreOnly()
    for predictor in (declared, core):
        track_episode(make_agent("gnn", predictor=predictor), 150, clutter_rate=0.5, max_tracks=16)
    # gnn passes its learnt flow to the predictor that declares VELOCITY_PRIOR, never to the other
    assert declared.with_prior > 10 and declared.with_prior < declared.starts
    assert core.starts > 10 and core.with_prior == 0


def test_extend_predictor_gains_are_the_kalman_steady_state_and_arguments_are_checked(scoped_registries):
    from agents import make_agent

    example = load("extend_predictor")
    assert example.alpha_beta_gains(1.0) == pytest.approx((0.75, 0.5))  # Kalata's λ = 1 values
    spec = sine_spec(dt=0.5, noise_std=0.2)
    filt = example.AlphaBetaPredictor(tracking_index=0.3)
    filt.reset(spec)
    state, z = filt.start(np.zeros((3, 2))), np.zeros((3, 2))
    for _ in range(300):
        state, _ = filt.predict(state)
        state = filt.update(state, z, np.ones(3, dtype=bool))
    predicted, _ = filt.predict(state)
    # the Kalman gain P⁻Hᵀ(HP⁻Hᵀ + R)⁻¹ of the covariance the Joseph form converged to is (α, β/dt)
    P = predicted.P
    gain = P[..., :, 0] / (P[..., 0, 0] + spec.noise_std**2)[..., None]
    np.testing.assert_allclose(gain, np.broadcast_to([filt.alpha, filt.beta / 0.5], gain.shape), rtol=1e-9)

    with pytest.raises(ValueError, match=r"tracking_index must be a finite number > 0, got 0"):
        example.AlphaBetaPredictor(tracking_index=0)
    example.register()
    with pytest.raises(ValueError, match=r"no argument 'tracking_idx'.*'tracking_index'"):
        make_agent("gnn", predictor="alpha-beta", tracking_idx=1.0)


def test_extend_learned_predictor_trains_saves_loads_and_tracks_without_torch(
    scoped_registries, tmp_path, monkeypatch, capsys
):
    import torch

    from predictors.training.model_file import ModelFileError, load_model, save_model

    example = load("extend_learned_predictor")
    metrics = example.main(["--out", str(tmp_path), "--steps", "200"])
    assert metrics["lost"] == 0 and metrics["frames_without_estimate"] == 0
    assert metrics["mean_error"] < 0.2
    assert "trained example-step-lstm (12 units" in capsys.readouterr().out

    # the model file: safetensors + JSON, and it round-trips
    model = load_model(tmp_path / "learned-step", kind=example.KIND, dim=2)
    assert (tmp_path / "learned-step.safetensors").is_file() and model.architecture == {"hidden": 12}
    assert model.meta["data"]["env_id"] == "PiecewiseTarget-v0"
    # the learned covariance: above the next measurement's own noise σ_n² = 0.01, not far above
    assert 0.01 < model.meta["calibration"]["residual_var"] < 0.03
    save_model(tmp_path / "again" / "copy", model)
    again = load_model(tmp_path / "again" / "copy", kind=example.KIND)
    assert again.meta == model.meta and again.tensors.keys() == model.tensors.keys()
    for name, tensor in model.tensors.items():
        np.testing.assert_array_equal(again.tensors[name], tensor)

    # the numpy inference (predictors.lstm_cell) equals the torch network of the same file
    net = example.build_network(12)
    net.load_state_dict({k: torch.from_numpy(v) for k, v in model.tensors.items()})
    network = example.StepNetwork.from_model(model)
    steps = np.random.default_rng(0).normal(0.0, 0.2, (5, 30, 2))
    with torch.no_grad():
        expected = net(torch.as_tensor(steps / network.scale, dtype=torch.float32)).numpy() * network.scale
    h = c = np.zeros((5, 12))
    for t in range(30):
        out, h, c = network.step(steps[:, t], h, c)
        np.testing.assert_allclose(out, expected[:, t], atol=1e-6)

    # tracking from the file needs no torch, and gives the same episode
    monkeypatch.setitem(sys.modules, "torch", None)  # any `import torch` now fails
    tracked = example.main(["--model", str(tmp_path / "learned-step"), "--steps", "200"])
    np.testing.assert_equal(tracked, metrics)

    with pytest.raises(ModelFileError, match=r"holds a 'lstm' model; expected 'example-step-lstm'"):
        example.LearnedStepPredictor(EXAMPLES.parent / "predictors" / "weights" / "lstm-cylinder")


def test_extend_agent_passes_the_agent_checks_and_tracks(scoped_registries, capsys):
    from agents import agent_traits, make_agent

    metrics = load("extend_agent").main(["--steps", "150"])  # check_agent runs inside
    assert metrics["lost"] == 0 and metrics["frames_without_estimate"] == 0
    assert metrics["mean_error"] < 0.2  # the detections' own error is ≈ 0.125 (σ_n = 0.1 per axis)
    assert "SineTarget-v0 + nearest, 150 frames" in capsys.readouterr().out
    assert agent_traits(make_agent("nearest")).position_rank == 1


def test_extend_agent_associates_within_its_gate_closed_form():
    example = load("extend_agent")
    agent = example.NearestNeighbourAgent(gate=1.0, max_misses=1)
    agent.reset(sine_spec(max_detections=4, max_tracks=4))

    def obs(*points):
        detections = np.zeros((4, 2), dtype=np.float32)
        detections[: len(points)] = np.reshape(points, (-1, 2))
        return {"detections": detections, "mask": (np.arange(4) < len(points)).astype(np.int8)}

    def live(report):
        on = report["mask"] == 1
        return report["ids"][on].tolist(), report["positions"][on].tolist(), report["detection"][on].tolist()

    assert live(agent.act(obs((0, 0), (5, 5)))) == ([0, 1], [[0, 0], [5, 5]], [0, 1])
    # each track takes the detection within its gate; the one far from both starts track 2
    ids, positions, rows = live(agent.act(obs((5.5, 5), (0.25, 0), (9, 9))))
    assert (ids, rows) == ([0, 1, 2], [1, 0, 2]) and positions == [[0.25, 0], [5.5, 5], [9, 9]]
    # nothing seen: every track coasts where it was (constant position), then is deleted
    assert live(agent.act(obs())) == (ids, positions, [-1, -1, -1])
    assert live(agent.act(obs())) == ([], [], [])
    with pytest.raises(ValueError, match=r"gate must be None or a finite distance > 0, got -1"):
        example.NearestNeighbourAgent(gate=-1)
    with pytest.raises(ValueError, match=r"max_misses must be an integer >= 0, got 1.5"):
        example.NearestNeighbourAgent(max_misses=1.5)


def test_extend_associator_registers_and_tracks_close_to_gnn(monkeypatch, capsys):
    from agents.tracking.associator import ASSOCIATOR_REGISTRY, Associator, available_associators

    monkeypatch.setattr(ASSOCIATOR_REGISTRY, "_factories", dict(ASSOCIATOR_REGISTRY._factories))
    example = load("extend_associator")
    assert "greedy-nearest" in available_associators()
    assert isinstance(example.GreedyNearest(), Associator)
    metrics = example.main(["--frames", "80", "--targets", "10"])
    new, gnn = metrics["greedy-nearest"], metrics["gnn"]
    # an easy scene (10 targets, few crossings): greedy is nearly optimal
    assert 0.6 < new["mota"] <= 1.0 and abs(new["mota"] - gnn["mota"]) < 0.05
    assert new["idf1"] > 0.8
    assert "greedy-nearest" in capsys.readouterr().out


def test_extend_associator_takes_the_nearest_free_detection_in_the_gate():
    from agents.tracking.associator import FrameContext
    from track_envs.values.types import Gaussian

    example = load("extend_associator")
    predicted = np.array([[0.0, 0.0], [1.0, 0.0], [5.0, 5.0]])
    z = np.array([[0.9, 0.0], [0.2, 0.0], [9.0, 9.0]])
    frame = FrameContext(
        prediction=Gaussian(predicted, np.broadcast_to(np.eye(2) * 0.1, (3, 2, 2)).copy()),
        predicted=predicted,
        z=z,
        gate=9.0,
        p_gate=0.99,
        recovery_inflation=1.0,
        noise=0.1,
        noise_scale=1.0,
        streak=np.zeros(3, np.int64),
        last=predicted,
        motion=0.0,
        region=(np.zeros(2), np.full(2, 10.0)),
        spec=sine_spec(),
    )
    out = example.GreedyNearest().associate(frame)
    # track 1 (cost 0.1 to z0) goes first and takes z0; track 0 then takes z1; track 2 has none in its gate
    assert out.det_of_track.tolist() == [1, 0, -1]
    np.testing.assert_array_equal(out.measurements[:2], z[[1, 0]])


def test_the_extending_section_links_a_tested_example_for_each_extension_point():
    import re

    page = (EXAMPLES.parent / "docs" / "architecture.md").read_text()
    start = page.index("\n## Extending\n")
    section = page[start : page.index("\n## ", start + 1)]
    linked = sorted(set(re.findall(r"examples/(extend_\w+)\.py", section)))
    assert linked == sorted(p.stem for p in EXAMPLES.glob("extend_*.py")) and len(linked) == 6
    tests = Path(__file__).read_text()
    assert all(f'load("{name}")' in tests for name in linked)


def test_score_with_motmetrics_runs_as_the_docs_write_it_and_both_scorers_agree(capsys):
    """The py-motmetrics recipe of docs/track_run.md on today's numpy (the np.asfarray shim)."""
    mm = pytest.importorskip("motmetrics")
    data = Path(mm.__file__).parent / "data" / "TUD-Campus"
    out = load("score_with_motmetrics").main([str(data / "gt.txt"), str(data / "test.txt")])
    theirs, ours = out["motmetrics"], out["track_envs"]
    # motmetrics' own figures for its tracker output (its test_motchallenge_files)
    assert theirs["mota"] == pytest.approx(0.526462, abs=1e-6) and theirs["num_switches"] == 7
    assert theirs["idf1"] == pytest.approx(0.557659, abs=1e-6)
    for key in ("mota", "idf1", "motp", "num_switches"):
        assert ours[key] == pytest.approx(theirs[key], abs=1e-12), key
    assert "py-motmetrics" in capsys.readouterr().out
