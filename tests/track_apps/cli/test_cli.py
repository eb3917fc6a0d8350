"""The ``track`` command: the dispatcher, flags that mean one thing everywhere, help for every
option, and every example of every ``--help`` parsed."""

from __future__ import annotations

import argparse
import importlib.util
import itertools
import shlex
import tomllib
import warnings
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

import track_envs
from agents import available_agents
from predictors import available_recipes
from track_apps.bench.cells import why_not
from track_apps.cli import COMMANDS, bench, main, run, train, tune
from track_apps.cli import arguments as arguments_mod
from track_apps.cli.arguments import example_block, example_lines, parse_assignments

ROOT = Path(__file__).parents[3]

#: Subcommand → its parser builder (``prog`` → parser).
PARSERS: dict[str, Callable[[str], argparse.ArgumentParser]] = {
    "bench": bench.build_parser,
    "run": run.build_parser,
    "train": train.build_parser,
    "tune": tune.build_parser,
    "list": bench.build_list_parser,
}


def walk(parser: argparse.ArgumentParser) -> Iterator[argparse.ArgumentParser]:
    """``parser`` and every subparser below it."""
    yield parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub in dict.fromkeys(action.choices.values()):
                yield from walk(sub)


def all_parsers(prefix: str = "track ") -> Iterator[argparse.ArgumentParser]:
    for name, build in PARSERS.items():
        yield from walk(build(prefix + name))


def _name(type_: object) -> object:
    return getattr(type_, "__qualname__", type_)


def options(parser: argparse.ArgumentParser) -> dict[str, argparse.Action]:
    return {o: a for a in parser._actions for o in a.option_strings}


# ---------------------------------------------------------------------------------- dispatcher


def test_every_subcommand_is_dispatched_and_listed_in_the_help(capsys):
    assert set(COMMANDS) == {"bench", "run", "train", "tune", "list"} == set(PARSERS)
    with pytest.raises(SystemExit) as exc:
        main(["--help"])
    assert exc.value.code == 0
    out = capsys.readouterr().out
    assert all(name in out for name in COMMANDS)
    with pytest.raises(SystemExit) as exc:
        main([])
    assert exc.value.code == 2
    with pytest.raises(SystemExit) as exc:
        main(["nope"])
    assert exc.value.code == 2 and "invalid choice" in capsys.readouterr().err


@pytest.mark.parametrize("name", sorted(PARSERS))
def test_each_subcommand_help_names_itself(capsys, name):
    with pytest.raises(SystemExit) as exc:
        main([name, "--help"])
    assert exc.value.code == 0
    assert f"usage: track {name}" in capsys.readouterr().out


def test_track_list_is_track_bench_list(capsys):
    assert main(["list"]) == 0
    listed = capsys.readouterr().out
    assert main(["bench", "list"]) == 0
    assert capsys.readouterr().out == listed
    for name in (*track_envs.ENV_IDS, *available_agents()):
        assert name in listed


def test_the_console_script_points_at_the_dispatcher():
    scripts = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["scripts"]
    assert scripts["track"] == "track_apps.cli:main"
    assert importlib.util.find_spec("track_apps.bench.__main__") is not None


def test_the_training_module_is_not_a_second_command():
    # `python -m predictors.training.cli lstm` trained an lstm without the line search
    assert importlib.util.find_spec("predictors.training.cli") is None


# ------------------------------------------------------------------------------ help and flags


def test_every_option_has_help():
    missing = [
        (p.prog, a.option_strings or a.dest)
        for p in all_parsers()
        for a in p._actions
        if not isinstance(a, argparse._SubParsersAction) and not a.help
    ]
    assert missing == []


def test_every_out_says_whether_it_is_a_file_a_stem_or_a_directory():
    kinds = ("a file", "a path without suffix", "a directory")
    outs = {p.prog: options(p)["--out"].help for p in all_parsers() if "--out" in options(p)}
    assert len(outs) >= 9
    assert {prog: h for prog, h in outs.items() if not any(k in str(h) for k in kinds)} == {}


def test_every_command_with_a_progress_bar_has_no_progress():
    with_bars = ["track bench run", "track run", "track tune train"]
    with_bars += [f"track train {k}" for k in available_recipes()]
    progs = {p.prog for p in all_parsers() if "--no-progress" in options(p)}
    assert set(with_bars) <= progs


def test_each_shared_flag_is_parsed_the_same_everywhere():
    types: dict[str, set] = {}
    for p in all_parsers():
        for flag, action in options(p).items():
            types.setdefault(flag, set()).add(_name(action.type))
    assert types["--env-kwargs"] == {"kwargs_type.<locals>.parse"}
    assert types["--agent-kwargs"] == {"parse_kwargs"}
    assert types["--declared-noise-std"] == {"float"}
    assert types["--added-noise-std"] == {"parse_noise"}
    # --seeds is the seed grammar N | A:B | a,b,c everywhere but tune evaluate, where it is the
    # number of held-out seeds (N seeds in both)
    seeds = {p.prog: options(p)["--seeds"].type for p in all_parsers() if "--seeds" in options(p)}
    assert {prog for prog, t in seeds.items() if t is not arguments_mod.parse_seeds} == {
        "track tune evaluate"
    }


def test_the_two_noises_have_two_names():
    declared = {p.prog for p in all_parsers() if "--declared-noise-std" in options(p)}
    added = {p.prog for p in all_parsers() if "--added-noise-std" in options(p)}
    assert declared == {"track run"}
    assert added == {f"track train {k}" for k in [*available_recipes(), "calibrate"]}


def test_train_help_lists_every_model_kind_and_calibrate(capsys):
    with pytest.raises(SystemExit):
        main(["train", "--help"])
    out = capsys.readouterr().out
    for kind in ("lstm", "nll-lstm", "mc-lstm", "displacement-lstm", "pose-lstm", "calibrate"):
        assert f"track train {kind} " in out


# ------------------------------------------------------------------------------ NAME=VALUE


def test_comma_separated_env_kwargs_are_never_read_as_one_string():
    argv = ["nll-lstm", "--env", "BeltSorter-v0", "--env-kwargs", "particle_kind=sphere,noise_std=1e-4"]
    args = train.build_parser().parse_args([*argv, "--out", "m"])
    assert args.env_kwargs == {"particle_kind": "sphere", "noise_std": 1e-4}
    args = tune.build_parser().parse_args(["evaluate", "--env-kwargs", "particle_kind=sphere,noise_std=1e-4"])
    assert args.env_kwargs == {"particle_kind": "sphere", "noise_std": 1e-4}


@pytest.mark.parametrize(
    ("text", "value"),
    [
        ("a=1,b=x", {"a": 1, "b": "x"}),
        (" a = 1e-4 , b=True,c=none", {"a": 1e-4, "b": True, "c": None}),
        ("label='a, b',n=2", {"label": "a, b", "n": 2}),
        ("sizes=[1, 2e-3, x],t=(1,)", {"sizes": (1, 2e-3, "x"), "t": (1,)}),
        ("path=data/run.csv", {"path": "data/run.csv"}),
    ],
)
def test_the_name_value_grammar(text, value):
    assert parse_assignments(text) == value


@pytest.mark.parametrize(
    ("text", "says"),
    [
        ("a=1,a=2", "a is given twice"),
        ("a=1e-4x", "'1e-4x' is not a number"),
        ("a=[1,2", "unclosed bracket"),
        ("a='x", "unbalanced quotes"),
        ("a", "use name=value"),
        ("2a=1", "not a keyword argument name"),
    ],
)
def test_a_bad_name_value_says_what_is_wrong(text, says):
    with pytest.raises(argparse.ArgumentTypeError, match=r"bad --env-kwargs .*" + says.replace("[", r"\[")):
        parse_assignments(text)


# ----------------------------------------------------------------------------- help examples


def epilogs(prefix: str) -> Iterator[tuple[str, str]]:
    """(prog, epilog) of the top-level parser and of every (sub)command's parser."""
    from track_apps.cli import build_parser

    yield "track", str(build_parser().epilog)
    for p in all_parsers(prefix):
        yield p.prog, p.epilog or ""


def parse_example(words: list[str]) -> argparse.Namespace:
    """Parse one example command line with the parser of its (sub)command."""
    name, rest, prog = words[1], words[2:], "track " + words[1]
    return PARSERS[name](prog).parse_args(rest)


def test_every_example_in_every_help_parses():
    examples = {line: prog for prog, epilog in epilogs("track ") for line in example_lines(epilog, "track")}
    assert len(examples) >= 30
    for line, prog in examples.items():
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # no example warns
            try:
                parse_example(shlex.split(line, comments=True))
            except SystemExit:
                pytest.fail(f"the example {line!r} of {prog} --help does not parse")


def test_every_example_line_is_a_command_or_a_continuation():
    for prog, epilog in epilogs("track "):
        lines = example_block(epilog)
        for before, line in itertools.pairwise(["", *lines]):
            assert line.strip().startswith("track") or before.endswith("\\"), (prog, line)


# ------------------------------------------------------------------------- applicability


def test_list_shows_exactly_the_combinations_that_run(capsys):
    assert main(["list"]) == 0
    listed: dict[str, set[str]] = {}
    env = None
    for line in capsys.readouterr().out.split("\n\nagents:")[0].splitlines()[1:]:
        words = line.split()
        if words and words[0] in track_envs.ENV_IDS:
            env = words[0]
        elif words and words[0] == "agents:" and env is not None:
            listed[env] = set() if words[1] == "none" else {w.strip(",") for w in words[1:]}
    for env_id in track_envs.ENV_IDS:
        assert listed[env_id] == {a for a in available_agents() if why_not(env_id, a) is None}
    assert listed["DetectionReplay-v0"] == set()


def test_a_cell_that_cannot_run_is_reported_not_dropped(capsys, tmp_path):
    # DetectionReplay-v0 has no truth: list says so, and run says why instead of "no cell applies"
    argv = ["bench", "run", "--envs", "DetectionReplay-v0", "--agents", "gnn", "--out", str(tmp_path)]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "DetectionReplay-v0 × gnn: the env has no ground truth" in err and "no cell applies" in err
    # in a mixed run the other env's cells run and the one that cannot is reported
    argv = ["bench", "run", "--envs", "DetectionReplay-v0,SineTarget-v0", "--agents", "detections"]
    argv += ["--seeds", "1", "--steps", "3", "--workers", "1", "--no-progress", "--out", str(tmp_path)]
    assert main(argv) == 0
    err = capsys.readouterr().err
    assert "DetectionReplay-v0 × detections: the env has no ground truth" in err
    assert "1 cells computed" in err
    # an env that no group of the suite runs is reported too
    argv = ["bench", "run", "--suite", "sorting", "--envs", "SineTarget-v0", "--out", str(tmp_path)]
    assert main(argv) == 2
    assert "SineTarget-v0 × every agent: no group of suite 'sorting' runs it" in capsys.readouterr().err


def test_a_predictor_not_meant_for_the_env_is_reported(capsys, tmp_path):
    argv = ["bench", "run", "--envs", "SineTarget-v0", "--agents", "gnn", "--predictors", "lstm"]
    assert main([*argv, "--out", str(tmp_path)]) == 2
    assert "SineTarget-v0 × gnn/lstm: the predictor is not meant for this env" in capsys.readouterr().err


def test_a_reader_that_closes_the_pipe_early_is_not_an_error(monkeypatch):
    """``track list | head -1``: when the reader has closed the pipe the command stops quietly (0)."""
    import os

    read, write = os.pipe()
    os.close(read)  # the reader is gone: every write raises BrokenPipeError
    stdout = os.fdopen(write, "w", buffering=1)
    monkeypatch.setattr("sys.stdout", stdout)
    try:
        assert main(["list"]) == 0
    finally:
        stdout.close()
