"""The pose agents' keywords: declared once (the loop's and the motions' settings), all taken by
``make_agent``, an unknown one refused with the valid names."""

from __future__ import annotations

import dataclasses
import inspect

import pytest

from agents import AGENTS, make_agent
from agents.pose.smc import PoseSmcAgent
from agents.pose.tracker import PoseBaselineAgent, PoseTracker, PoseTrackingOptions
from predictors.pose import ConstantVelocityPose
from predictors.pose_lstm.motion import SmcPoseMotion, SmcSettings
from track_apps.bench.cells import expand, load_suite
from track_envs.infra.registry import (
    UnknownArgumentError,
    keyword_parameters,
    split_keywords,
    takes_keywords_of,
)

LOOP = [f.name for f in dataclasses.fields(PoseTrackingOptions)]
SMC = [f.name for f in dataclasses.fields(SmcSettings)]
#: A valid value other than the default for every keyword of the loop and the SMC motion.
LOOP_VALUES = {"oks_threshold": 0.4, "assignment": "greedy", "keypoint_threshold": 0.1, "min_pose_score": 0.2,
               "min_keypoints": 3, "initial_lifetime": 2, "area_factor": 0.3, "report_coasting": True,
               "max_active": 7}  # fmt: skip
SMC_VALUES = {"particles": 12, "window": 4, "alpha": 0.3, "elite": 0.25, "epistemic": False,
              "aleatoric": False, "fixed_sigma": 0.5, "recurrence": "carried",
              "share_windows": False, "device": "cpu"}  # fmt: skip


def test_the_values_cover_every_keyword_with_a_value_other_than_the_default():
    assert sorted(LOOP_VALUES) == sorted(LOOP) and sorted(SMC_VALUES) == sorted(SMC)
    assert all(LOOP_VALUES[k] != v for k, v in dataclasses.asdict(PoseTrackingOptions()).items())
    assert all(SMC_VALUES[k] != v for k, v in dataclasses.asdict(SmcSettings()).items())


def test_the_agents_list_the_keywords_of_their_settings_with_the_defaults_declared_there():
    assert AGENTS.arguments("pose-baseline") == ["smoothing", *LOOP]
    assert AGENTS.arguments("pose-smc") == [
        "model",
        "max_filters",
        *SMC,
        *[k for k in LOOP if k != "max_active"],
    ]
    defaults = {
        **dataclasses.asdict(PoseTrackingOptions()),
        **dataclasses.asdict(SmcSettings()),
        "smoothing": 0.5,
    }
    for agent in (PoseBaselineAgent, PoseSmcAgent):
        for p in inspect.signature(agent).parameters.values():
            if p.name in defaults:
                assert p.kind is p.KEYWORD_ONLY and p.default == defaults[p.name], (agent, p.name)
    assert inspect.signature(ConstantVelocityPose).parameters["smoothing"].default == 0.5
    assert list(inspect.signature(PoseTracker).parameters) == ["motion", *LOOP]
    assert list(inspect.signature(SmcPoseMotion).parameters) == ["predictor", *SMC]


def test_make_agent_takes_every_keyword_and_hands_it_to_the_loop_or_the_motion():
    baseline = make_agent("pose-baseline", smoothing=1.0, **LOOP_VALUES)
    assert isinstance(baseline, PoseBaselineAgent) and baseline.options == PoseTrackingOptions(**LOOP_VALUES)
    assert isinstance(baseline.motion, ConstantVelocityPose) and baseline.motion.smoothing == 1.0
    loop = {k: v for k, v in LOOP_VALUES.items() if k != "max_active"}
    smc = make_agent("pose-smc", max_filters=5, **SMC_VALUES, **loop)
    assert isinstance(smc, PoseSmcAgent) and smc.options == PoseTrackingOptions(**loop, max_active=5)
    assert isinstance(smc.motion, SmcPoseMotion) and smc.motion.settings == SmcSettings(**SMC_VALUES)
    assert (smc.motion.P, smc.motion.L, smc.motion.recurrence) == (12, 4, "carried")
    defaults = make_agent("pose-smc")
    assert defaults.options == PoseTrackingOptions(max_active=100)
    assert defaults.motion.settings == SmcSettings()


@pytest.mark.parametrize(
    ("name", "kwargs", "bad"),
    [("pose-baseline", {"particles": 10}, "'particles'"),
     ("pose-baseline", {"smoothin": 0.5}, "'smoothin'"),
     ("pose-smc", {"particle": 10, "window": 3}, "'particle'"),
     ("pose-smc", {"max_active": 5}, "'max_active'"),
     ("pose-smc", {"smoothing": 0.5, "oks": 0.2}, "'smoothing', 'oks'")],
)  # fmt: skip
def test_an_unknown_keyword_is_refused_naming_it_and_the_valid_ones(name, kwargs, bad):
    valid = AGENTS.arguments(name)
    assert valid is not None
    with pytest.raises(
        UnknownArgumentError, match=rf"^agent '{name}' has no arguments? {bad}; its arguments are"
    ) as e:
        make_agent(name, **kwargs)
    assert str(valid) in str(e.value)
    agent_class = {"pose-baseline": PoseBaselineAgent, "pose-smc": PoseSmcAgent}[name]
    with pytest.raises(UnknownArgumentError, match=rf"^{agent_class.__name__} has no arguments? {bad}") as e:
        agent_class(**kwargs)
    assert str(valid) in str(e.value)


def test_the_loop_and_the_motion_refuse_unknown_keywords_too():
    with pytest.raises(
        TypeError, match=r"^PoseTracker has no argument 'max_filters'; its arguments are \['motion'"
    ):
        PoseTracker(ConstantVelocityPose(), max_filters=3)
    with pytest.raises(ValueError, match=r"^SmcPoseMotion has no argument 'particle'; .*'device'\]$"):
        SmcPoseMotion(None, particle=3)
    with pytest.raises(ValueError, match="particles"):
        SmcSettings(particles=0)
    with pytest.raises(ValueError, match="oks_threshold"):
        PoseTrackingOptions(oks_threshold=0.0)


def test_the_okada2020_suite_passes_only_keywords_the_agents_take():
    for cell in expand(load_suite("okada2020")):
        AGENTS.check_arguments(cell.agent, dict(cell.agent_kwargs))


def test_keyword_sources_are_dataclasses_or_signatures_and_a_name_cannot_be_taken_twice():
    assert [p.name for p in keyword_parameters(ConstantVelocityPose)] == ["smoothing"]
    assert [p.name for p in keyword_parameters(SmcSettings)] == SMC
    assert split_keywords(SmcSettings, {"particles": 3, "oks_threshold": 0.5}) == (
        {"particles": 3},
        {"oks_threshold": 0.5},
    )

    def build(smoothing: float = 1.0, **options: object) -> None:
        del smoothing, options

    with pytest.raises(ValueError, match="duplicate parameter name: 'smoothing'"):
        takes_keywords_of(ConstantVelocityPose)(build)
    takes = takes_keywords_of(ConstantVelocityPose, exclude=("smoothing",))(build)
    assert list(inspect.signature(takes).parameters) == ["smoothing"]
