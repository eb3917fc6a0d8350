"""Cell expansion, applicability, suites and name checking."""

from __future__ import annotations

import argparse
import json
import re
from dataclasses import replace

import pytest

import track_envs
from agents import available_agents
from predictors import available_predictors, predictor_applies_to
from track_apps.bench import NO_PREDICTOR, Cell, Group, expand, load_suite
from track_apps.bench.cells import NO_TRUTH_ENVS, applicable, override
from track_apps.cli.arguments import parse_sweep, parse_value
from track_apps.cli.bench import main

#: Pollithy et al. (2020), Fig. 7: the measurement noise on the belt from 0 to 0.5 mm.
NOISE_SWEEP = (0.0, 1e-4, 2e-4, 3e-4, 4e-4, 5e-4)


def test_quick_suite_covers_every_applicable_combination_with_two_seeds():
    cells = expand(load_suite("quick"))
    combos = {(c.env_id, c.agent, c.predictor) for c in cells}
    # every env with truth (a replay of detections has nothing to score)
    assert {c.env_id for c in cells} == set(track_envs.ENV_IDS) - set(NO_TRUTH_ENVS)
    assert "DetectionReplay-v0" in NO_TRUTH_ENVS
    assert len(cells) == 2 * len(combos)
    assert {c.seed for c in cells} == {0, 1}
    # keypoints: only the pose trackers, without a predictor
    pose_trackers = {("pose-baseline", NO_PREDICTOR), ("pose-smc", NO_PREDICTOR)}
    assert {(a, p) for e, a, p in combos if e == "KeypointWalkers-v0"} == pose_trackers
    # gnn runs once per predictor meant for the env (the belt LSTMs on the belt envs only);
    # predictor-free agents once with "-"
    for env_id in set(track_envs.ENV_IDS) - {"KeypointWalkers-v0", *NO_TRUTH_ENVS}:
        meant = {p for p in available_predictors() if predictor_applies_to(p, env_id)}
        assert {p for e, a, p in combos if e == env_id and a == "gnn"} == meant
        assert ("lstm" in meant) == (env_id in ("BeltSorter-v0", "BeltReplay-v0"))
        assert {p for e, a, p in combos if e == env_id and a in ("detections", "pf")} == {NO_PREDICTOR}
        assert "pose-baseline" not in {a for e, a, _ in combos if e == env_id}
    assert all(c.steps is not None and c.steps <= 100 for c in cells)


def test_applicability():
    assert applicable("KeypointWalkers-v0", "gnn", ["kf-cv"]) == []
    assert applicable("BeltSorter-v0", "pose-baseline", ["kf-cv"]) == []
    assert applicable("BeltSorter-v0", "gnn", ["kf-cv", "kf-ca"]) == ["kf-cv", "kf-ca"]
    assert applicable("SineTarget-v0", "pf", ["kf-cv"]) == [NO_PREDICTOR]


def test_full_suite_has_ten_seeds_and_the_noise_sweep():
    cells = expand(load_suite("full"))
    belt = [c for c in cells if c.env_id == "BeltSorter-v0" and c.agent == "gnn" and c.predictor == "kf-ca"]
    assert {dict(c.env_kwargs)["noise_std"] for c in belt} == {0.0, 1e-4, 2e-4, 3e-4, 4e-4, 5e-4}
    assert {c.seed for c in cells} == set(range(10))
    assert all(c.steps is None for c in cells)


def test_sweep_and_override_expand_to_the_product():
    groups = override(
        load_suite("quick"), envs=("SineTarget-v0",), agents=("gnn", "pf"), predictors=("kf-cv",),
        seeds=(3, 4, 5), sweep=(("p_detect", (0.9, 0.7)),),
    )  # fmt: skip
    cells = expand(groups)
    assert len(cells) == 2 * 2 * 3  # (gnn/kf-cv, pf) x 2 values x 3 seeds
    assert {dict(c.env_kwargs)["p_detect"] for c in cells} == {0.9, 0.7}


def test_cell_key_is_stable_and_names_the_file():
    a = Cell("BeltSorter-v0", "gnn", "kf-ca", 3, (("noise_std", 1e-4),), 1, 50)
    b = Cell.from_dict(a.to_dict())
    assert a == b and a.key == b.key and len(a.key) == 16
    assert a.key != Cell("BeltSorter-v0", "gnn", "kf-ca", 4, (("noise_std", 1e-4),), 1, 50).key
    assert a.filename.endswith(f"_{a.key}.json") and a.filename.startswith("BeltSorter-v0_gnn_kf-ca_s3")
    # the hash must not change between releases: finished records would be recomputed
    assert a.key == "41bfe25679c5656c"
    assert Cell("SineTarget-v0", "pf", "-", 0).key == "3405bc9b42b0c5b7"


def test_every_result_changing_field_is_in_the_key_and_the_params():
    base = Cell("BeltSorter-v0", "gnn", "kf-ca", 0, (("noise_std", 1e-4),), 1, 100)
    variants = [
        replace(base, steps=700),
        replace(base, episodes=3),
        replace(base, steps=None),
        replace(base, env_kwargs=(("noise_std", 2e-4),)),
        replace(base, agent_kwargs=(("p_gate", 0.99),)),
    ]
    assert len({base.key, *(v.key for v in variants)}) == 1 + len(variants)
    assert len({base.params(), *(v.params() for v in variants)}) == 1 + len(variants)
    assert replace(base, seed=5).params() == base.params()  # only the seed is pooled
    assert replace(base, episodes=3, agent_kwargs=(("p_gate", 0.99),)).params() == (
        ("noise_std", 1e-4), ("steps", 100), ("episodes", 3), ("agent.p_gate", 0.99),
    )  # fmt: skip
    with_kwargs = replace(base, agent_kwargs=(("p_gate", 0.99),))
    assert Cell.from_dict(with_kwargs.to_dict()) == with_kwargs


def test_kwargs_read_from_json_are_hashable_and_keep_the_key():
    cell = Cell("BeltReplay-v0", "detections", "-", 0, (("frames", (0, 50)),))
    back = Cell.from_dict(json.loads(json.dumps(cell.to_dict())))  # the tuple comes back a list
    assert back == cell and back.key == cell.key and hash(back) == hash(cell)


def test_quick_suite_replay_cells_have_noise():
    cells = [c for c in expand(load_suite("quick")) if c.env_id == "BeltReplay-v0"]
    assert cells and all(dict(c.env_kwargs).get("noise_std", 0.0) > 0 for c in cells)
    assert {c.seed for c in cells} == {0, 1}
    other = [c for c in expand(load_suite("quick")) if c.env_id != "BeltReplay-v0"]
    assert all("noise_std" not in dict(c.env_kwargs) for c in other)  # the others keep their defaults
    # selecting the replay from the suite keeps its group's noise
    only = expand(override(load_suite("quick"), envs=("BeltReplay-v0",)))
    assert {c.key for c in only} == {c.key for c in cells}
    full = [c for c in expand(load_suite("full")) if c.env_id == "BeltReplay-v0"]
    assert full and all(dict(c.env_kwargs)["noise_std"] > 0 for c in full)


def test_envs_flag_selects_from_a_suite():
    groups = override(load_suite("full"), envs=("SineTarget-v0", "BeltSorter-v0"))
    cells = expand(groups)
    assert {c.env_id for c in cells} == {"SineTarget-v0", "BeltSorter-v0"}
    assert all("noise_std" not in dict(c.env_kwargs) for c in cells if c.env_id == "SineTarget-v0")
    assert {dict(c.env_kwargs)["noise_std"] for c in cells if c.env_id == "BeltSorter-v0"} == set(NOISE_SWEEP)


@pytest.mark.parametrize(
    ("group", "valid"),
    [
        (Group(envs=("Nope-v0",)), "BeltSorter-v0"),
        (Group(agents=("kalman",)), "pose-baseline"),
        (Group(predictors=("lstm9",)), "kf-ca"),
        (Group(envs=("BeltSorter-v0",), sweep=(("noise_stdd", (1.0,)),)), "noise_std"),
    ],
)
def test_unknown_names_list_the_valid_ones(group, valid):
    with pytest.raises(ValueError, match="valid names are") as err:
        expand([group])
    assert valid in str(err.value)


@pytest.mark.parametrize(
    ("flag", "value", "valid"),
    [("--envs", "Nope-v0", track_envs.ENV_IDS), ("--agents", "gnn,nope", available_agents())],
)
def test_cli_unknown_names_list_the_valid_ones(capsys, flag, value, valid):
    with pytest.raises(SystemExit) as exc:
        main(["run", flag, value, "--out", "unused"])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert "nope" in err.lower() and all(v in err for v in valid)


def test_cli_unknown_suite_and_sweep_name(capsys, tmp_path):
    assert main(["run", "--suite", "huge", "--out", str(tmp_path)]) == 2
    assert "quick" in capsys.readouterr().err
    assert main(["run", "--envs", "SineTarget-v0", "--sweep", "nois=1", "--out", str(tmp_path)]) == 2
    assert "noise_std" in capsys.readouterr().err


def test_toml_suite(tmp_path):
    path = tmp_path / "suite.toml"
    path.write_text(
        '[[group]]\nenvs = ["SineTarget-v0"]\nagents = ["pf"]\nseeds = 3\nsteps = 20\n'
        "sweep = { p_detect = [0.9, 0.8] }\n"
        '[[group]]\nenvs = ["BeltSorter-v0"]\nagents = ["gnn"]\npredictors = ["kf-cv"]\nseeds = [7]\n'
    )
    cells = expand(load_suite(str(path)))
    assert len(cells) == 3 * 2 + 1
    assert Cell("BeltSorter-v0", "gnn", "kf-cv", 7) in cells


def test_help_is_complete(capsys):
    with pytest.raises(SystemExit):
        main(["run", "--help"])
    out = capsys.readouterr().out
    for flag in ("--suite", "--envs", "--agents", "--predictors", "--seeds", "--episodes", "--steps"):
        assert flag in out
    for flag in ("--sweep", "--agent-kwargs", "--workers", "--engine", "--address", "--out", "examples:"):
        assert flag in out
    assert "track bench tables" in out and "agent_kwargs" in out


def test_list_names_everything(capsys):
    assert main(["list"]) == 0
    out = capsys.readouterr().out
    for name in (*track_envs.ENV_IDS, *available_agents(), *available_predictors()):
        assert name in out


@pytest.mark.parametrize(
    ("text", "value"),
    [
        ("3", 3), ("-1", -1), ("1e-4", 1e-4), ("0.5", 0.5), ("inf", float("inf")), ("True", True),
        ("false", False), ("none", None), ("sphere", "sphere"), ("kf-ca", "kf-ca"),
        ("data/run.csv", "data/run.csv"), ("'a b'", "a b"), ('"3"', "3"),
    ],
)  # fmt: skip
def test_parse_value(text, value):
    parsed = parse_value(text)
    assert parsed == value and type(parsed) is type(value)


@pytest.mark.parametrize(
    ("text", "says"),
    [
        ("noise_std=1e-4x", "'1e-4x' is not a number"),
        ("noise_std=0,,1", "value 2 of noise_std: empty value"),
        ("noise_std=0,'a", "unbalanced quotes"),
        ("noise_std=0,0.0", "noise_std=0.0 is given twice"),
        ("noise std=1", "not a keyword argument name"),
        ("noise_std=", "use name=value"),
        ("noise_std", "use name=value"),
    ],
)
def test_parse_sweep_says_what_is_wrong(text, says):
    with pytest.raises(argparse.ArgumentTypeError, match=re.escape(says)):
        parse_sweep(text)
    assert parse_sweep("noise_std=0, 1e-4,abc") == ("noise_std", (0, 1e-4, "abc"))


@pytest.mark.parametrize("value", ["abc", True])
def test_a_string_or_bool_for_a_number_kwarg_is_rejected_by_name(value):
    group = Group(envs=("BeltSorter-v0",), sweep=(("noise_std", (0.0, value)),))
    with pytest.raises(ValueError, match=r"BeltSorter-v0 noise_std=.*: noise_std must be a number \(default"):
        expand([group])


def test_toml_agent_kwargs_and_bad_sweep(tmp_path):
    path = tmp_path / "suite.toml"
    path.write_text('envs = ["SineTarget-v0"]\nagents = ["gnn"]\npredictors = ["kf-cv"]\nseeds = 1\n'
                    "agent_kwargs = { p_gate = 0.99 }\n")  # fmt: skip
    (cell,) = expand(load_suite(str(path)))
    assert cell.agent_kwargs == (("p_gate", 0.99),)
    path.write_text("sweep = { noise_std = 0.1 }\n")
    with pytest.raises(ValueError, match="sweep of noise_std must be a list"):
        load_suite(str(path))
