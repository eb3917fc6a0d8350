"""``track train`` is generic over the training recipes: a new learned family edits no CLI code."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from predictors.training.recipes import RECIPES, TrainingRecipe, register_recipe
from predictors.training.settings import RecipeOption
from track_apps.cli import main as track
from track_apps.cli.train import main


@pytest.fixture
def dummy_family(monkeypatch):
    """A recipe registered the way a new family registers one (kept out of the other tests)."""
    monkeypatch.setattr(RECIPES, "_factories", dict(RECIPES._factories))
    ran: list[object] = []

    depth = RecipeOption("depth", 3, "layers of the dummy", type=int)

    def train(settings):
        from predictors.training.command import load_data

        data = load_data(settings.data)
        out = Path(settings.out).with_suffix(".json")
        written = {"command": settings.command, "depth": settings.options["depth"], "tracks": len(data)}
        out.write_text(json.dumps(written))
        ran.append(settings)
        print(f"wrote {out}")
        return out

    register_recipe("dummy-lstm", TrainingRecipe("dummy-lstm", "a dummy learned family", train, (depth,)))
    return ran


def test_train_help_lists_every_registered_recipe_with_its_help(dummy_family, capsys):
    with pytest.raises(SystemExit):
        track(["train", "--help"])
    out = capsys.readouterr().out
    listed = {line.split()[0]: line for line in out.splitlines() if line.startswith("    ") and line.split()}
    for kind in ("lstm", "nll-lstm", "mc-lstm", "displacement-lstm", "pose-lstm", "dummy-lstm", "calibrate"):
        assert kind in listed  # a subcommand line, with its help
    assert "a dummy learned family" in listed["dummy-lstm"]
    assert "scaled identity" in listed["lstm"]
    assert "{lstm,mc-lstm,nll-lstm,displacement-lstm,pose-lstm,dummy-lstm,calibrate}" in out


def test_a_registered_recipe_trains_through_track_train(dummy_family, tmp_path, capsys):
    out = tmp_path / "m"
    argv = ["dummy-lstm", "--sine", "--periods", "2", "--depth", "5", "--out", str(out)]
    assert main(argv) == 0
    written = json.loads(out.with_suffix(".json").read_text())
    assert written["depth"] == 5 and written["tracks"] > 0
    assert written["command"] == "track train dummy-lstm --sine --periods 2 --depth 5 --out " + str(out)
    assert "wrote" in capsys.readouterr().out and len(dummy_family) == 1


def test_a_recipes_value_error_is_one_line(dummy_family, tmp_path, capsys):
    assert main(["dummy-lstm", "--tracks", "t.csv", "--out", str(tmp_path / "m")]) == 2
    assert capsys.readouterr().err.startswith("track train: error: --tracks needs --dt")


def test_track_train_runs_the_lstm_line_search_as_lstms_post_training_step():
    from track_apps.cli.train import POST_TRAINING
    from track_apps.lstm_line_search import lstm_tuner

    assert POST_TRAINING.get("lstm") is lstm_tuner and POST_TRAINING.get("nll-lstm") is None
