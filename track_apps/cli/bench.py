"""``track bench``: list, run, tables, claims (also ``python -m track_apps.bench``)."""

from __future__ import annotations

import argparse
import functools
import inspect
import os
import re
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import gymnasium as gym

import track_envs
from agents import AGENTS, available_agents
from predictors import KINDS, PREDICTORS, available_predictors, motion_models
from track_apps.bench import cells as cells_mod
from track_apps.bench.cells import NO_PREDICTOR, Group
from track_apps.cli import arguments

PROG = "track bench"

EPILOG = """\
examples:
  track bench list
  track bench run --suite quick --out results/quick            # the demo: every env x agent x predictor
  track bench run --suite quick --workers 1 --out results/q1   # in-process, no pool
  track bench run --envs BeltSorter-v0 --agents gnn --predictors kf-cv,kf-ca \\
                  --seeds 5 --steps 300 --sweep noise_std=0,1e-4,2e-4,3e-4,4e-4,5e-4 --out results/noise
  track bench run --envs SineTarget-v0 --agents gnn --agent-kwargs p_gate=0.99,max_misses=3 --out results/gate
  track bench run --suite full --quick --out results/full-quick      # any suite's quick variant
  track bench run --suite my_suite.toml --engine ray --out results/ray          # local Ray instance
  track bench run --suite full --engine ray --address auto --out results/full   # an existing Ray cluster
  track bench tables results/noise                              # rebuild tables and plots
  track bench run --suite pollithy2020 --workers 2 --out results/p20   # a paper's evaluation
  track bench claims pollithy2020 results/p20 --out docs        # its figures and claims table

A cell is (env, env kwargs, steps, episodes, agent, predictor, agent kwargs, seed); each finished
cell is one JSON record in --out, written atomically. Every argument is checked (each distinct env
and agent built once) before the first cell runs; a bad one stops the run with one error line.
A combination of the suite that cannot run (an agent that does not track the env's targets, a
predictor not meant for the env, an env without truth) is reported with the reason before the run;
'track list' shows the same rule. Tables pool the seeds of cells that agree in everything else
(the params column). Rerunning with the same --out computes only the missing cells, so an
interrupted run (Ctrl-C, a killed worker) resumes where it stopped. Agents that take no predictor
("detections", "pf", "pose-baseline") run once per env with predictor "-". Same seeds give the
same metrics on every engine; only the "timing" part of a record differs.
"""

SUITE_HELP = """\
suites (track_apps/bench/suites/NAME.toml, run by name; or a .toml file of your own): "quick" = every
env x every agent/predictor that applies x 2 seeds, 100-step episodes; "full" = 10 seeds,
full-length episodes, plus the BeltSorter-v0 noise_std sweep 0..5e-4 of Pollithy et al. (2020)
Fig. 7 (in both, BeltReplay-v0 runs with noise_std=1e-4 so that seeds differ); "sorting" = gnn with
every belt predictor over that sweep and two nozzle bars; paper suites (pollithy2020, okada2020).
--quick runs any suite's quick variant. A TOML suite holds [[group]] tables with keys envs,
exclude_envs, agents, predictors, seeds (count or list), episodes, steps, env_kwargs (table),
sweep (table of lists), agent_kwargs (table), name and quick (the group's keys in the --quick
variant, or false to leave it out; a top-level quick table is every group's default).
Flags given with a suite override that key in every group, except --envs, which selects: a
group keeps those of its envs also given (and is dropped if none is).
Values (--sweep, --agent-kwargs): the NAME=VALUE grammar of 'track --help': numbers, true/false,
none, names, 'quoted strings' or [lists]."""


def describe(factory: Any) -> str:
    """First docstring line of a registry factory (a ``functools.partial`` names its arguments)."""
    extra = ""
    if isinstance(factory, functools.partial):
        extra = (
            " ["
            + ", ".join([repr(a) for a in factory.args] + [f"{k}={v!r}" for k, v in factory.keywords.items()])
            + "]"
        )
        factory = factory.func
    doc = inspect.getdoc(factory) or ""
    line = doc.splitlines()[0] if doc else factory.__name__
    if "module docstring" in line:  # the module's first line says more
        line = (inspect.getdoc(inspect.getmodule(factory)) or line).splitlines()[0]
    line = re.sub(r"\[`?(?:[\w.]+\.)?([^`\[\]]+)`?\]\[[\w.]*\]", r"\1", line)  # a link: its text
    line = re.sub(r":\w+:`~?(?:[\w.]+\.)?([^`]+)`", r"\1", line).replace("``", "")
    return line + extra


def cmd_list(args: argparse.Namespace) -> int:
    """Print every env, agent and predictor, what each is and where it applies (`why_not`)."""
    from gymnasium.envs.registration import load_env_creator

    why_not = cells_mod.why_not
    print("envs:")
    for env_id in track_envs.ENV_IDS:
        entry = gym.spec(env_id).entry_point
        creator = load_env_creator(entry) if isinstance(entry, str) else entry
        agents = [a for a in available_agents() if why_not(env_id, a) is None]
        print(f"  {env_id:<20} {describe(creator)}")
        if agents:
            print(f"  {'':<20} agents: {', '.join(agents)}")
        else:
            reasons = sorted({str(why_not(env_id, a)) for a in available_agents()})
            print(f"  {'':<20} agents: none ({'; '.join(reasons)})")
    print("\nagents:")
    for name in available_agents():
        envs = [e for e in track_envs.ENV_IDS if why_not(e, name) is None]
        takes = (
            "takes --predictors" if cells_mod.agent_takes_predictor(name) else f"predictor {NO_PREDICTOR!r}"
        )
        print(f"  {name:<20} {describe(AGENTS.factory(name))}")
        print(f"  {'':<20} envs: {', '.join(envs) or 'none'}; {takes}")
    print("\npredictors:")
    users = [a for a in available_agents() if cells_mod.agent_takes_predictor(a)]
    for name in available_predictors():
        envs = [e for e in track_envs.ENV_IDS if any(why_not(e, a, name) is None for a in users)]
        print(f"  {name:<20} {describe(PREDICTORS.factory(name))}")
        print(f"  {'':<20} used by: {', '.join(users)}; envs: {', '.join(envs) or 'none'}")
    print("\nmotion models of the other kinds (the predictors above are the Gaussian kind):")
    for kind, what in KINDS.items():
        if kind == "gaussian":
            continue
        print(f"  {kind}: {what}")
        for model in motion_models(kind):
            print(f"    {model.name:<18} {model.summary}")
            print(f"    {'':<18} taken by: {', '.join(model.agents) or 'none'}")
    print(f"\nsuites: {', '.join(cells_mod.suite_names())} (or a .toml file; see {args.prog} run --help)")
    return 0


def build_groups(args: argparse.Namespace) -> tuple[Group, ...]:
    """The suite named by ``--suite`` (default quick) with the other flags applied to every group."""
    groups = cells_mod.load_suite(args.suite, quick=args.quick)
    return cells_mod.override(
        groups,
        envs=args.envs,
        agents=args.agents,
        predictors=args.predictors,
        seeds=args.seeds,
        episodes=args.episodes,
        steps=args.steps,
        sweep=tuple(args.sweep) if args.sweep else None,
        agent_kwargs=args.agent_kwargs,
    )


def unselected_envs(args: argparse.Namespace, groups: Sequence[Group]) -> list[str]:
    """The envs of ``--envs`` that no group of the suite runs (so no cell of them is planned)."""
    planned = {e for g in groups for e in g.env_ids()}
    return [e for e in args.envs or () if e not in planned]


def print_skipped(prog: str, skipped: Sequence[tuple[Any, str]]) -> None:
    """One warning line on stderr per file of the out dir that is not a readable record."""
    for path, reason in skipped:
        print(f"{prog}: warning: skipped {path}: {reason}", file=sys.stderr)


def cmd_run(args: argparse.Namespace) -> int:
    from track_apps.bench.runner import CellError, check_cells, is_finished, run_cells, scan_records
    from track_apps.bench.tables import aggregate, terminal_table, write_tables

    prog = f"{args.prog} run"
    try:
        groups = build_groups(args)
        cells, skipped = cells_mod.plan(groups)
    except (ValueError, OSError) as exc:
        print(f"{prog}: error: {exc}", file=sys.stderr)
        return 2
    lines = [
        f"{e} × every agent: no group of suite {args.suite!r} runs it" for e in unselected_envs(args, groups)
    ]
    lines += cells_mod.format_skipped(skipped)
    if lines:
        print(f"not run (does not apply), {len(skipped)} combinations:", file=sys.stderr)
        for line in lines:
            print(f"  {line}", file=sys.stderr)
    if not cells:
        print(f"{prog}: error: no cell applies (see above; check --envs / --agents)", file=sys.stderr)
        return 2
    try:
        check_cells(c for c in cells if not is_finished(Path(args.out), c))
    except CellError as exc:
        print(f"{prog}: error: {exc} (no cell was run)", file=sys.stderr)
        return 2
    print(f"{len(cells)} cells -> {args.out} (engine {args.engine})", file=sys.stderr)
    try:
        result = run_cells(
            cells,
            args.out,
            engine=args.engine,
            workers=args.workers,
            address=args.address,
            progress=not args.no_progress,
            check=False,
        )
    except KeyboardInterrupt:
        print("\ninterrupted: finished cells are saved; rerun the same command to resume", file=sys.stderr)
        return 130
    except RuntimeError as exc:
        print(f"{prog}: error: {exc}", file=sys.stderr)
        return 1
    print(
        f"{result.computed} cells computed, {result.skipped} already done, {result.wall_s:.1f} s",
        file=sys.stderr,
    )
    keys = {c.key for c in cells}
    scan = scan_records(args.out)
    print_skipped(prog, scan.skipped)
    records = [r for r in scan.records if r["key"] in keys]
    write_tables(records, args.out)
    print(terminal_table(aggregate(records)))
    print(f"\ntables and plots in {args.out}/ (results.md, summary.csv, records.csv, plots/)")
    return 0


def cmd_tables(args: argparse.Namespace) -> int:
    from track_apps.bench.runner import scan_records
    from track_apps.bench.tables import aggregate, terminal_table, write_tables

    prog = f"{args.prog} tables"
    if not os.path.isdir(args.dir):
        print(f"{prog}: error: no directory {args.dir!r}", file=sys.stderr)
        return 2
    scan = scan_records(args.dir)
    print_skipped(prog, scan.skipped)
    records = scan.records
    if not records:
        print(f"{prog}: error: no records in {args.dir!r}", file=sys.stderr)
        return 2
    t0 = time.perf_counter()
    paths = write_tables(records, args.dir)
    print(terminal_table(aggregate(records)))
    skipped = f", {len(scan.skipped)} files skipped (see the warnings)" if scan.skipped else ""
    print(f"\n{len(records)} records{skipped}; wrote {len(paths)} files in {time.perf_counter() - t0:.1f} s")
    return 0


def cmd_claims(args: argparse.Namespace) -> int:
    from track_apps.bench.claims import claims_module
    from track_apps.bench.runner import scan_records

    prog = f"{args.prog} claims"
    try:
        module = claims_module(args.suite)
    except ValueError as exc:
        print(f"{prog}: error: {exc}", file=sys.stderr)
        return 2
    if not os.path.isdir(args.dir):
        print(f"{prog}: error: no directory {args.dir!r}", file=sys.stderr)
        return 2
    scan = scan_records(args.dir)
    print_skipped(prog, scan.skipped)
    if not scan.records:
        print(f"{prog}: error: no records in {args.dir!r}", file=sys.stderr)
        return 2
    paths = module.write_claims(scan.records, args.out, wall_s=args.wall_s, label=args.label)
    print(f"{len(scan.records)} records; wrote {', '.join(str(p) for p in paths)}")
    return 0


def add_list_parser(sub: Any, prog: str) -> argparse.ArgumentParser:
    """The ``list`` subcommand (``track list`` and ``track bench list``)."""
    p = sub.add_parser("list", help="envs, agents and predictors, what each is and where it applies")
    p.set_defaults(func=cmd_list, prog=prog)
    return p


def build_parser(prog: str = PROG) -> argparse.ArgumentParser:
    """The argparse parser of ``track bench`` (``prog``: the name it answers to)."""
    fmt = argparse.RawDescriptionHelpFormatter
    epilog = EPILOG.replace(PROG + " ", prog + " ")
    parser = argparse.ArgumentParser(
        prog=prog,
        description="Benchmark tracker agents and predictors across the track-envs environments.",
        epilog=epilog,
        formatter_class=fmt,
    )
    parser.set_defaults(prog=prog)
    sub = parser.add_subparsers(dest="command", required=True, metavar="{list,run,tables,claims}")
    add_list_parser(sub, prog)
    p = sub.add_parser(
        "run",
        help="run a suite and print its table",
        description="Run the cells of a suite (with the flags applied) and print their table.",
        epilog=SUITE_HELP + "\n\n" + epilog,
        formatter_class=fmt,
    )
    p.add_argument(
        "--suite",
        default="quick",
        help=f"a suite name ({', '.join(cells_mod.suite_names())}; see 'track list') "
        "or a .toml suite file (default quick)",
    )
    p.add_argument(
        "--quick",
        action="store_true",
        help="the suite's quick variant (each group's quick keys; minutes instead of an hour)",
    )
    p.add_argument(
        "--envs", type=arguments.names_type("env", track_envs.ENV_IDS), help="comma list of env ids"
    )
    p.add_argument(
        "--agents", type=arguments.names_type("agent", available_agents()), help="comma list of agents"
    )
    p.add_argument(
        "--predictors",
        type=arguments.names_type("predictor", available_predictors()),
        help="comma list of predictors (for agents that take one, e.g. gnn)",
    )
    arguments.add_seeds(
        p, help="seeds of every cell: N (0..N-1), A:B (A..B-1) or a,b,c (default: the suite's)"
    )
    p.add_argument("--episodes", type=int, help="episodes per cell (metrics: their mean)")
    p.add_argument("--steps", type=int, help="steps per episode (default: the suite's; full: env length)")
    p.add_argument(
        "--sweep",
        type=arguments.parse_sweep,
        action="append",
        metavar="NAME=V1,V2,...",
        help="sweep an env kwarg, e.g. noise_std=0,1e-4 or p_detect=0.9,0.7 (repeat for a grid)",
    )
    arguments.add_agent_kwargs(
        p,
        help="make_agent keyword arguments for every cell, e.g. p_gate=0.99,max_misses=3 "
        "(gnn passes the ones it does not take to its predictor)",
    )
    arguments.add_workers(p, default=None, help="local processes running the cells")
    p.add_argument("--engine", choices=["local", "ray"], default="local", help="default local")
    p.add_argument("--address", help="Ray cluster address for --engine ray (e.g. auto, ray://host:10001)")
    arguments.add_out(
        p, kind="directory", help="the cells' records, tables and plots", default="results/bench"
    )
    arguments.add_no_progress(p)
    p.set_defaults(func=cmd_run)
    p = sub.add_parser("tables", help="rebuild tables and plots from the records in DIR")
    p.add_argument(
        "dir", metavar="DIR", help="a --out directory of a run (tables and plots are written there)"
    )
    p.set_defaults(func=cmd_tables)
    p = sub.add_parser(
        "claims",
        help="a paper's figures and claims table from the records of its suite in DIR",
        epilog=f"example:\n  {prog} claims pollithy2020 results/pollithy2020 --out docs",
        formatter_class=fmt,
    )
    p.add_argument("suite", metavar="SUITE", help="a suite with a claims table (pollithy2020, ...)")
    p.add_argument("dir", metavar="DIR", help=f"the records of {prog} run --suite SUITE")
    arguments.add_out(p, kind="directory", help="writes OUT/SUITE.md and OUT/figures/SUITE/", default="docs")
    p.add_argument("--wall-s", type=float, help="wall time of the run in seconds, stated in the table")
    p.add_argument("--label", default="", help="text appended to the title (e.g. ' (quick run)')")
    p.set_defaults(func=cmd_claims)
    return parser


def main(argv: Sequence[str] | None = None, prog: str = PROG) -> int:
    """Entry point of ``track bench`` (``prog``: the name it answers to)."""
    args = build_parser(prog).parse_args(argv)
    return int(args.func(args))


def build_list_parser(prog: str = "track list") -> argparse.ArgumentParser:
    """The parser of ``track list`` (no options but ``--help``)."""
    return argparse.ArgumentParser(
        prog=prog,
        description="Every env, agent and predictor: what each is and where it applies (the rule "
        "'track bench run' uses: a combination listed here runs, any other is reported as not applying).",
    )


def list_main(argv: Sequence[str] | None = None, prog: str = "track list") -> int:
    """Entry point of ``track list`` (the same listing as ``track bench list``)."""
    build_list_parser(prog).parse_args(argv)
    return cmd_list(argparse.Namespace(prog=PROG))
