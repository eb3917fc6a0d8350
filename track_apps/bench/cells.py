"""Cells, suites and applicability: what the benchmark runs.

A **cell** is one unit of work: (env id, env kwargs, agent, predictor, agent kwargs, seed) plus
the episode budget (episodes, steps per episode). Its [`Cell.key`][track_apps.bench.Cell.key] is a stable hash
of exactly those fields, so the record file of a cell has the same name on every machine and every run; every
field but the seed is also one of the cell's [`Cell.params`][track_apps.bench.Cell.params], which the report
groups seeds by.

A **suite** is a list of [`Group`][track_apps.bench.Group] s, read from a TOML file
([`load_suite`][track_apps.bench.load_suite]; the shipped ones are ``track_apps/bench/suites/NAME.toml``); a
group is a cartesian product (envs × agents × predictors × sweep values × seeds) that
[`expand`][track_apps.bench.expand] turns into the cells that *apply*, by the one rule
[`why_not`][track_apps.bench.cells.why_not] (which ``track list`` shows too):

- the env reports ground truth to score against (not ``DetectionReplay-v0``);
- an agent applies to an env when its position rank matches the env's ``position_shape``
  ([`agents.agent_applies_to`][agents.agent_applies_to]: point trackers on point envs, pose trackers on
  keypoints);
- a predictor applies to an agent that takes a ``predictor`` argument (``"gnn"``); an agent
  without one (``"detections"``, ``"pf"``, ``"pose-baseline"``) runs once with predictor ``"-"``.

[`plan`][track_apps.bench.plan] also returns the combinations that do not apply, with the reason, so that the
command reports them instead of dropping them.
"""

from __future__ import annotations

import hashlib
import inspect
import itertools
import json
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import asdict, dataclass, field, replace
from functools import cache
from pathlib import Path
from typing import Any

import gymnasium as gym

import track_envs
from agents import AGENTS, agent_applies_to, available_agents
from agents.base import agent_takes_predictor, agent_traits
from predictors import available_predictors, predictor_applies_to

#: The predictor column of a cell whose agent takes no predictor.
NO_PREDICTOR = "-"


def freeze(value: Any) -> Any:
    """``value`` with every list turned into a tuple (recursively), so kwargs read from JSON or
    TOML are hashable; the JSON of the result, and so a cell's key, is unchanged."""
    if isinstance(value, list | tuple):
        return tuple(freeze(v) for v in value)
    return value


def kwarg_items(data: Mapping[str, Any] | None) -> tuple[tuple[str, Any], ...]:
    """Sorted, hashable ``(name, value)`` pairs of a kwargs mapping."""
    return tuple(sorted((str(k), freeze(v)) for k, v in dict(data or {}).items()))


@dataclass(frozen=True)
class Cell:
    """One benchmark run: ``episodes`` episodes of ``env_id`` with one agent/predictor and seed.

    Attributes:
        env_id: A registered env id, e.g. ``"BeltSorter-v0"``.
        agent: A registered agent name.
        predictor: A registered predictor name, or ``"-"`` for agents that take none.
        seed: Seed of the first episode (env and agent); later episodes derive theirs from it.
        env_kwargs: Keyword arguments for ``gym.make`` as sorted ``(name, value)`` pairs.
        episodes: Episodes to run; the record's metrics are their mean.
        steps: ``max_episode_steps`` for ``gym.make``; ``None`` keeps the env's own length.
        agent_kwargs: Keyword arguments for ``make_agent`` as sorted ``(name, value)`` pairs
            (``gnn`` passes the ones it does not take on to its predictor).
    """

    env_id: str
    agent: str
    predictor: str
    seed: int
    env_kwargs: tuple[tuple[str, Any], ...] = ()
    episodes: int = 1
    steps: int | None = None
    agent_kwargs: tuple[tuple[str, Any], ...] = ()

    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready dict (``env_kwargs`` and ``agent_kwargs`` as dicts)."""
        out = asdict(self)
        out["env_kwargs"] = dict(self.env_kwargs)
        out["agent_kwargs"] = dict(self.agent_kwargs)
        return out

    def params(self) -> tuple[tuple[str, Any], ...]:
        """Everything but the env, agent, predictor and seed that changes the cell's result.

        The env kwargs by name, then ``steps`` (absent: the env's own length), ``episodes``
        (absent: 1) and the agent kwargs as ``agent.NAME``. Records that differ only in their
        seed have equal params; the report pools exactly those.
        """
        out = list(self.env_kwargs)
        if self.steps is not None:
            out.append(("steps", self.steps))
        if self.episodes != 1:
            out.append(("episodes", self.episodes))
        out += [(f"agent.{k}", v) for k, v in self.agent_kwargs]
        return tuple(out)

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> Cell:
        """Inverse of [`to_dict`][track_apps.bench.Cell.to_dict]."""
        kwargs = kwarg_items(data.get("env_kwargs"))
        agent_kwargs = kwarg_items(data.get("agent_kwargs"))
        return cls(
            env_id=data["env_id"],
            agent=data["agent"],
            predictor=data["predictor"],
            seed=int(data["seed"]),
            env_kwargs=kwargs,
            episodes=int(data.get("episodes", 1)),
            steps=None if data.get("steps") is None else int(data["steps"]),
            agent_kwargs=agent_kwargs,
        )

    @property
    def key(self) -> str:
        """Stable 16-hex-digit hash of the cell (sha256 of its canonical JSON).

        Empty ``agent_kwargs`` are left out of the hashed JSON, so cells without agent kwargs
        keep the keys (and record files) they had before the field existed.
        """
        data = self.to_dict()
        if not data["agent_kwargs"]:
            del data["agent_kwargs"]
        text = json.dumps(data, sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(text.encode()).hexdigest()[:16]

    @property
    def filename(self) -> str:
        """Record file name: readable prefix plus [`key`][track_apps.bench.Cell.key]."""
        return f"{self.env_id}_{self.agent}_{self.predictor}_s{self.seed}_{self.key}.json"


@dataclass(frozen=True)
class Group:
    """A cartesian product of cells (one table of a suite file).

    Attributes:
        envs: Env ids; empty means every registered env.
        agents: Agent names; empty means every registered tracker
            (`trackers`).
        predictors: Predictor names for agents that take one; empty means every registered one.
        seeds: Seeds of the cells.
        episodes: Episodes per cell.
        steps: Steps per episode (``None``: the env's own length).
        env_kwargs: Fixed env kwargs for every cell.
        sweep: Env kwarg name → values; one cell per value (several names: every combination).
        agent_kwargs: Fixed ``make_agent`` kwargs for every cell.
        exclude_envs: Env ids left out of an empty ``envs`` ("every env but these").
    """

    envs: tuple[str, ...] = ()
    agents: tuple[str, ...] = ()
    predictors: tuple[str, ...] = ()
    seeds: tuple[int, ...] = (0, 1)
    episodes: int = 1
    steps: int | None = None
    env_kwargs: tuple[tuple[str, Any], ...] = ()
    sweep: tuple[tuple[str, tuple[Any, ...]], ...] = field(default=())
    agent_kwargs: tuple[tuple[str, Any], ...] = ()
    exclude_envs: tuple[str, ...] = ()

    def env_ids(self) -> tuple[str, ...]:
        """The envs the group runs: ``envs``, or every registered env but ``exclude_envs``."""
        return self.envs or tuple(e for e in track_envs.ENV_IDS if e not in self.exclude_envs)


#: Envs without truth (a replay of a user's detections): nothing to score, so no cell of them
#: applies ([`why_not`][track_apps.bench.cells.why_not]; the env class declares ``has_truth = False``).
NO_TRUTH_ENVS = ("DetectionReplay-v0",)


def check_names(kind: str, names: Iterable[str], valid: Sequence[str]) -> None:
    """Raise ``ValueError`` naming every unknown entry of ``names`` and listing ``valid``."""
    unknown = [n for n in names if n not in valid]
    if unknown:
        raise ValueError(f"unknown {kind} {', '.join(map(repr, unknown))}; valid names are {list(valid)}")


@cache
def env_position_shape(env_id: str) -> tuple[int, ...]:
    """``position_shape`` of an env (built once per process with default kwargs)."""
    return env_shape(env_id)[0]


@cache
def env_shape(env_id: str) -> tuple[tuple[int, ...], int]:
    """``(position_shape, max_targets)`` of an env built with default kwargs."""
    env = gym.make(env_id)
    try:
        unwrapped: Any = env.unwrapped
        return tuple(unwrapped.position_shape), int(unwrapped.max_targets)
    finally:
        env.close()


def env_kwarg_defaults(env_id: str) -> dict[str, Any] | None:
    """Keyword arguments the env's constructor takes with their defaults (``inspect.Parameter.empty``
    where there is none), or ``None`` when it takes ``**kwargs``."""
    from gymnasium.envs.registration import load_env_creator

    entry = gym.spec(env_id).entry_point
    creator: Any = load_env_creator(entry) if isinstance(entry, str) else entry
    params = inspect.signature(creator).parameters.values()
    if any(p.kind is inspect.Parameter.VAR_KEYWORD for p in params):
        return None
    return {p.name: p.default for p in params if p.name != "render_mode"}


def env_kwarg_names(env_id: str) -> list[str] | None:
    """Keyword arguments the env's constructor takes, or ``None`` when it takes ``**kwargs``."""
    defaults = env_kwarg_defaults(env_id)
    return None if defaults is None else list(defaults)


def _is_number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


def check_kwarg_type(env_id: str, name: str, value: Any, default: Any) -> None:
    """Raise ``ValueError`` when ``value`` cannot stand where the constructor's ``default`` does.

    A number default (``noise_std=0.0``) takes a number, a bool default a bool and a string
    default a string; a ``None`` default or none at all takes anything (the env checks it).
    """
    if default is None or default is inspect.Parameter.empty:
        return
    if isinstance(default, bool):
        ok, want = isinstance(value, bool), "true or false"
    elif _is_number(default):
        ok, want = _is_number(value), "a number"
    elif isinstance(default, str):
        ok, want = isinstance(value, str), "a string"
    else:
        return
    if not ok:
        raise ValueError(f"{env_id} {name}={value!r}: {name} must be {want} (default {default!r})")


def trackers() -> list[str]:
    """The registered agents a group without ``agents`` runs: every agent but the oracles that
    read the truth (``AgentTraits(needs_truth=True)``,
    [`agents.one_step.OneStepAgent`][agents.one_step.OneStepAgent]), which run only where a suite names
    them."""
    return [a for a in available_agents() if not agent_traits(AGENTS.factory(a)).needs_truth]


def env_has_truth(env_id: str) -> bool:
    """Whether ``env_id`` reports ground truth (its env class does not declare ``has_truth = False``)."""
    from gymnasium.envs.registration import load_env_creator

    from track_envs.infra.declared import declared_value

    entry = gym.spec(env_id).entry_point
    creator: Any = load_env_creator(entry) if isinstance(entry, str) else entry
    return declared_value(creator, "has_truth", bool, True)


def why_not(env_id: str, agent: str, predictor: str | None = None) -> str | None:
    """Why the cell (``env_id``, ``agent``[, ``predictor``]) cannot run, or ``None`` when it can.

    The reason is a phrase about "the env", "the agent" or "the predictor", to print after the
    combination ([`format_skipped`][track_apps.bench.cells.format_skipped]).

    The one applicability rule of the benchmark (``track list`` and ``track bench run`` both ask
    it): the env must report truth to score against; the agent must track the env's targets
    ([`agents.agent_applies_to`][agents.agent_applies_to]: position rank, and how many targets it follows at
    once); a ``predictor`` other than ``"-"`` needs an agent that takes one and must be meant for the env
    ([`predictors.predictor_applies_to`][predictors.predictor_applies_to]: the belt LSTMs run on the belt envs
    only).
    """
    if not env_has_truth(env_id):
        return "the env has no ground truth to score against (track its detections with 'track run')"
    position_shape, max_targets = env_shape(env_id)
    if not agent_applies_to(agent, position_shape):
        return f"the agent tracks no targets with positions of shape {position_shape}"
    if not agent_applies_to(agent, position_shape, max_targets):
        return f"the agent tracks fewer targets at once than the env's up to {max_targets}"
    if predictor is None or predictor == NO_PREDICTOR:
        return None
    if not agent_takes_predictor(agent):
        return f"the agent takes no predictor (it runs with predictor {NO_PREDICTOR!r})"
    if not predictor_applies_to(predictor, env_id):
        return "the predictor is not meant for this env"
    return None


def agent_applies_to_env(env_id: str, agent: str) -> bool:
    """Whether some cell of ``agent`` on ``env_id`` can run ([`why_not`][track_apps.bench.cells.why_not])."""
    return why_not(env_id, agent) is None


def applicable(env_id: str, agent: str, predictors: Sequence[str]) -> list[str]:
    """Predictor column values for ``agent`` on ``env_id``: ``[]`` if the agent does not apply,
    ``["-"]`` if it takes no predictor, else those of ``predictors`` meant for the env
    (all by [`why_not`][track_apps.bench.cells.why_not])."""
    if not agent_applies_to_env(env_id, agent):
        return []
    if not agent_takes_predictor(agent):
        return [NO_PREDICTOR]
    return [p for p in predictors if why_not(env_id, agent, p) is None]


@dataclass(frozen=True)
class Skipped:
    """A combination of a suite that does not run, and why ([`why_not`][track_apps.bench.cells.why_not]).

    Attributes:
        env_id: The env id.
        agent: The agent name.
        predictor: The predictor, or ``None`` when the agent does not apply with any.
        reason: Why the cell cannot run.
    """

    env_id: str
    agent: str
    predictor: str | None
    reason: str


def format_skipped(skipped: Sequence[Skipped]) -> list[str]:
    """One line per env and reason: ``"ENV × AGENT[/PREDICTOR], ...: REASON"``, in first-seen order."""
    lines: dict[tuple[str, str], list[str]] = {}
    for s in skipped:
        what = s.agent if s.predictor is None else f"{s.agent}/{s.predictor}"
        lines.setdefault((s.env_id, s.reason), []).append(what)
    return [f"{env} × {', '.join(whats)}: {reason}" for (env, reason), whats in lines.items()]


def validate_group(group: Group) -> None:
    """Raise ``ValueError`` for unknown env, agent, predictor or sweep names (listing valid ones)."""
    check_names("env", group.envs, track_envs.ENV_IDS)
    check_names("env", group.exclude_envs, track_envs.ENV_IDS)
    check_names("agent", group.agents, available_agents())
    check_names("predictor", group.predictors, available_predictors())
    if group.episodes < 1:
        raise ValueError(f"episodes must be >= 1, got {group.episodes}")
    if group.steps is not None and group.steps < 1:
        raise ValueError(f"steps must be >= 1, got {group.steps}")
    if not group.seeds:
        raise ValueError("no seeds given")
    values = list(group.env_kwargs) + [(n, v) for n, vs in group.sweep for v in vs]
    for name, vs in group.sweep:
        if not vs:
            raise ValueError(f"sweep of {name} has no values")
    for env_id in group.env_ids():
        defaults = env_kwarg_defaults(env_id)
        if defaults is None:
            continue
        check_names(f"env kwarg for {env_id}", dict.fromkeys(n for n, _ in values), list(defaults))
        for name, value in values:
            check_kwarg_type(env_id, name, value, defaults[name])


def expand(groups: Iterable[Group]) -> list[Cell]:
    """Every applicable cell of ``groups``, in order, without duplicates ([`plan`][track_apps.bench.plan] also
    says which combinations do not apply and why)."""
    return plan(groups)[0]


def plan(groups: Iterable[Group]) -> tuple[list[Cell], list[Skipped]]:
    """The cells of ``groups`` that apply (in order, without duplicates) and every combination
    of env, agent and predictor of theirs that does not, with the reason
    (`why_not`)."""
    cells: dict[str, Cell] = {}
    skipped: dict[tuple[str, str, str | None], Skipped] = {}
    for group in groups:
        validate_group(group)
        sweep_names = [n for n, _ in group.sweep]
        sweep_values = list(itertools.product(*(v for _, v in group.sweep)))
        for env_id in group.env_ids():
            for agent in group.agents or trackers():
                reason = why_not(env_id, agent)
                if reason is not None:
                    skipped.setdefault((env_id, agent, None), Skipped(env_id, agent, None, reason))
                    continue
                predictors = [NO_PREDICTOR]
                if agent_takes_predictor(agent):
                    predictors = []
                    for p in group.predictors or available_predictors():
                        reason = why_not(env_id, agent, p)
                        if reason is None:
                            predictors.append(p)
                        else:
                            skipped.setdefault((env_id, agent, p), Skipped(env_id, agent, p, reason))
                for predictor in predictors:
                    for values in sweep_values:
                        kwargs = dict(group.env_kwargs) | dict(zip(sweep_names, values, strict=True))
                        for seed in group.seeds:
                            items = tuple(sorted(kwargs.items()))
                            cell = Cell(
                                env_id,
                                agent,
                                predictor,
                                int(seed),
                                items,
                                group.episodes,
                                group.steps,
                                tuple(sorted(group.agent_kwargs)),
                            )
                            cells.setdefault(cell.key, cell)
    return list(cells.values()), list(skipped.values())


def override(groups: Sequence[Group], **changes: Any) -> tuple[Group, ...]:
    """``groups`` with the non-``None`` ``changes`` applied to every group (CLI flags over a suite).

    ``envs`` selects rather than replaces: a group keeps those of its envs
    ([`Group.env_ids`][track_apps.bench.Group.env_ids]) that are also in ``envs`` and is dropped if none is.
    So ``--envs BeltReplay-v0`` on a suite with a group per env family runs just that env's group,
    with that group's env kwargs. Every other key replaces the group's value.
    """
    changes = {k: v for k, v in changes.items() if v is not None}
    envs = changes.pop("envs", None)
    out = []
    for group in groups:
        if envs is not None:
            chosen = tuple(e for e in envs if e in group.env_ids())
            if group.envs:  # keep the group's own order
                chosen = tuple(e for e in group.envs if e in envs)
            if not chosen:
                continue
            group = replace(group, envs=chosen, exclude_envs=())
        out.append(replace(group, **changes))
    return tuple(out)


#: The folder (in package ``track_apps.bench``) of the shipped suites: every ``NAME.toml`` is suite ``NAME``.
SUITE_FOLDER = "suites"


def packaged_suites() -> dict[str, Path]:
    """Name → path of every TOML suite shipped in [`SUITE_FOLDER`][track_apps.bench.cells.SUITE_FOLDER]
    (``quick``, ``full``, ``sorting``, ``pollithy2020``, ...)."""
    from importlib import resources

    folder = resources.files("track_apps.bench") / SUITE_FOLDER
    if not folder.is_dir():
        return {}
    return {
        entry.name.removesuffix(".toml"): Path(str(entry))
        for entry in sorted(folder.iterdir(), key=lambda e: e.name)
        if entry.name.endswith(".toml")
    }


#: The suites [`suite_names`][track_apps.bench.suite_names] lists first, in this order (the others follow by
#: name).
MAIN_SUITES = ("quick", "full", "sorting")


def suite_names() -> list[str]:
    """Every suite name [`load_suite`][track_apps.bench.load_suite] accepts: ``quick``, ``full``, ``sorting``,
    then the other shipped TOMLs by name."""
    shipped = packaged_suites()
    return [*(n for n in MAIN_SUITES if n in shipped), *(n for n in shipped if n not in MAIN_SUITES)]


def load_suite(source: str, *, quick: bool = False) -> tuple[Group, ...]:
    """A shipped suite by name (``"quick"``, ``"full"``, ``"sorting"``, ``"pollithy2020"``, ...:
    ``track_apps/bench/suites/NAME.toml``) or a suite from a TOML file.

    A TOML suite holds one or more ``[[group]]`` tables (or the group's keys at the top level)::

        [[group]]
        name = "fig6"                 # optional label, for the reader
        envs = ["BeltSorter-v0"]      # default: every env (but exclude_envs)
        exclude_envs = ["BeltReplay-v0"]  # with no envs: every env but these
        agents = ["gnn"]              # default: every agent that applies
        predictors = ["kf-cv", "kf-ca"]
        seeds = 5                     # a count (0..4) or a list of seeds
        episodes = 1
        steps = 200                   # omit for the env's own episode length
        env_kwargs = { particle_kind = "sphere" }
        sweep = { noise_std = [0.0, 2e-4, 4e-4] }
        agent_kwargs = { p_gate = 0.99 }  # make_agent kwargs (gnn: also its predictor's)
        quick = { seeds = 1, steps = 100 }  # the group in the --quick variant (false: left out)

    A top-level ``[quick]`` table gives every group's quick keys that do not set their own; a
    group with neither runs unchanged in the quick variant.

    Args:
        source: A suite name ([`suite_names`][track_apps.bench.suite_names]) or a path ending in ``.toml``.
        quick: The suite's quick variant: each group's ``quick`` keys replace its own.

    Raises:
        ValueError: for an unknown name or a bad key or value.
    """
    shipped = packaged_suites()
    if source in shipped:
        path: str | Path = shipped[source]
    elif source.endswith(".toml"):
        path = source
    else:
        raise ValueError(f"unknown suite {source!r}; valid names are {suite_names()} or a .toml file")
    import tomllib

    with open(path, "rb") as fh:
        data = tomllib.load(fh)
    if "group" in data:
        default_quick = data.get("quick", {})
        check_names("suite top-level key", data, ["group", "quick", "description"])
        tables = list(data["group"])
    else:
        default_quick, tables = {}, [data]
    groups = []
    for table in tables:
        table = dict(table)
        variant = table.pop("quick", default_quick)
        if quick:
            if variant is False:
                continue
            if not isinstance(variant, dict):
                raise ValueError(f"quick must be a table of group keys or false, got {variant!r}")
            table |= variant
        groups.append(group_from_mapping(table))
    return tuple(groups)


def group_from_mapping(data: Mapping[str, Any]) -> Group:
    """A [`Group`][track_apps.bench.Group] from a TOML table (see
    [`load_suite`][track_apps.bench.load_suite])."""
    allowed = {"envs", "agents", "predictors", "seeds", "episodes", "steps", "env_kwargs", "sweep"}
    allowed |= {"agent_kwargs", "name", "quick", "exclude_envs"}
    check_names("suite key", data, sorted(allowed))
    seeds = data.get("seeds", 2)
    for name, values in dict(data.get("sweep", {})).items():
        if not isinstance(values, list):
            raise ValueError(f"sweep of {name} must be a list of values, got {values!r}")
    return Group(
        envs=tuple(data.get("envs", ())),
        agents=tuple(data.get("agents", ())),
        predictors=tuple(data.get("predictors", ())),
        seeds=tuple(range(seeds)) if isinstance(seeds, int) else tuple(int(s) for s in seeds),
        episodes=int(data.get("episodes", 1)),
        steps=data.get("steps"),
        env_kwargs=kwarg_items(data.get("env_kwargs")),
        sweep=tuple((k, freeze(list(v))) for k, v in dict(data.get("sweep", {})).items()),
        agent_kwargs=kwarg_items(data.get("agent_kwargs")),
        exclude_envs=tuple(data.get("exclude_envs", ())),
    )
