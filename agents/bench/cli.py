"""The ``track-bench`` command (also ``python -m agents.bench``): list, run, report."""

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
from agents.bench import cells as cells_mod
from agents.bench.cells import NO_PREDICTOR, Group
from predictors import PREDICTORS, available_predictors

EPILOG = """\
examples:
  track-bench list
  track-bench run --suite quick --out results/quick            # the demo: every env x agent x predictor
  track-bench run --suite quick --workers 1 --out results/q1   # in-process, no pool
  track-bench run --envs BeltSorter-v0 --agents gnn --predictors kf-cv,kf-ca \\
                  --seeds 5 --steps 300 --sweep noise_std=0,1e-4,2e-4,3e-4,4e-4,5e-4 --out results/noise
  track-bench run --envs SineTarget-v0 --agents gnn --agent-kwargs p_gate=0.99,max_misses=3 --out results/gate
  track-bench run --suite my_suite.toml --engine ray --out results/ray          # local Ray instance
  track-bench run --suite full --engine ray --address auto --out results/full   # an existing Ray cluster
  track-bench report results/noise                              # rebuild tables and plots
  track-bench run --suite pollithy2020 --workers 2 --out results/p20   # a paper's evaluation
  track-bench claims pollithy2020 results/p20 --out docs        # its figures and claims table

A cell is (env, env kwargs, steps, episodes, agent, predictor, agent kwargs, seed); each finished
cell is one JSON record in --out, written atomically. Every argument is checked (each distinct env
and agent built once) before the first cell runs; a bad one stops the run with one error line.
Tables pool the seeds of cells that agree in everything else (the params column). Rerunning
with the same --out computes only the missing cells, so an interrupted run (Ctrl-C, a killed
worker) resumes where it stopped. Agents that take no predictor ("detections", "pf",
"pose-baseline") run once per env with predictor "-". Same seeds give the
same metrics on every engine; only the "timing" part of a record differs.
"""

SUITE_HELP = """\
suites: "quick" = every env x every agent/predictor that applies x 2 seeds, 100-step episodes;
"full" = 10 seeds, full-length episodes, plus the BeltSorter-v0 noise_std sweep 0..5e-4 of
Pollithy et al. (2020) Fig. 7. In both, BeltReplay-v0 runs with noise_std=1e-4 so that seeds differ.
Shipped TOML suites (agents/bench/suites/NAME.toml, e.g. pollithy2020) run by name; --quick runs
their quick variant. A TOML suite holds [[group]] tables with keys envs, agents, predictors, seeds
(count or list), episodes, steps, env_kwargs (table), sweep (table of lists), agent_kwargs (table),
name and quick (the group's keys in the --quick variant, or false to leave it out).
Flags given with a suite override that key in every group, except --envs, which selects: a
group that lists envs keeps those also given (and is dropped if none is).
Values (--sweep, --agent-kwargs): numbers, true/false, none, names, or 'quoted strings'."""


def _names(text: str) -> tuple[str, ...]:
    return tuple(n.strip() for n in text.split(",") if n.strip())


def parse_seeds(text: str) -> tuple[int, ...]:
    """``"5"`` → 0..4; ``"3:7"`` → 3..6; ``"0,4,9"`` → those seeds."""
    try:
        if "," in text:
            return tuple(int(s) for s in text.split(",") if s.strip())
        if ":" in text:
            lo, hi = text.split(":")
            return tuple(range(int(lo), int(hi)))
        return tuple(range(int(text)))
    except ValueError:
        raise argparse.ArgumentTypeError(f"bad --seeds {text!r}: use N, A:B or a,b,c") from None


#: A bare word read as a string value (a name such as ``sphere`` or ``kf-ca``, a path).
WORD = re.compile(r"[A-Za-z_/.~][\w./~+-]*")
BOOLS = {"true": True, "false": False}
NONES = {"none", "null"}


def parse_value(text: str) -> Any:
    """One CLI value: ``int`` (``3``), ``float`` (``1e-4``, ``0.5``, ``inf``, ``nan``), bool
    (``true``/``false``, any case), ``None`` (``none``/``null``), a quoted string (``'a b'``) or a
    bare word (``sphere``, ``data/run.csv``) as a string.

    Raises:
        ValueError: for an empty value, unbalanced quotes, or text that is none of these
            (e.g. ``1e-4x``, which starts like a number but is not one).
    """
    text = text.strip()
    if not text:
        raise ValueError("empty value")
    low = text.lower()
    if low in BOOLS:
        return BOOLS[low]
    if low in NONES:
        return None
    try:
        return int(text)
    except ValueError:
        pass
    try:
        return float(text)
    except ValueError:
        pass
    if len(text) >= 2 and text[0] == text[-1] and text[0] in "'\"":
        return text[1:-1]
    if text[0] in "'\"" or text[-1] in "'\"":
        raise ValueError(f"{text!r} has unbalanced quotes")
    if WORD.fullmatch(text) and not text[0].isdigit():
        return text
    raise ValueError(f"{text!r} is not a number, true/false, none or a name (quote other strings: 'a b')")


def parse_assignment(flag: str, text: str) -> tuple[str, str]:
    """``"name=rest"`` → ``("name", "rest")``, checking that ``name`` is an identifier."""
    name, sep, rest = text.partition("=")
    name = name.strip()
    if not sep or not rest.strip():
        raise argparse.ArgumentTypeError(f"bad {flag} {text!r}: use name=value")
    if not name.isidentifier():
        raise argparse.ArgumentTypeError(f"bad {flag} {text!r}: {name!r} is not a keyword argument name")
    return name, rest


def parse_sweep(text: str) -> tuple[str, tuple[Any, ...]]:
    """``"noise_std=0,1e-4,2e-4"`` → ``("noise_std", (0, 0.0001, 0.0002))``; values as in
    :func:`parse_value`, each at most once."""
    name, rest = parse_assignment("--sweep", text)
    values = []
    for i, part in enumerate(rest.split(",")):
        try:
            values.append(parse_value(part))
        except ValueError as exc:
            msg = f"bad --sweep {text!r}: value {i + 1} of {name}: {exc}"
            raise argparse.ArgumentTypeError(msg) from None
    seen: list[Any] = []
    for v in values:
        if any(v == s and isinstance(v, bool) == isinstance(s, bool) for s in seen):
            raise argparse.ArgumentTypeError(f"bad --sweep {text!r}: {name}={v!r} is given twice")
        seen.append(v)
    return name, tuple(values)


def parse_kwargs(text: str) -> tuple[tuple[str, Any], ...]:
    """``"p_gate=0.99,max_misses=3"`` → sorted ``(name, value)`` pairs (values as in
    :func:`parse_value`)."""
    out: dict[str, Any] = {}
    for part in text.split(","):
        name, rest = parse_assignment("--agent-kwargs", part)
        if name in out:
            raise argparse.ArgumentTypeError(f"bad --agent-kwargs {text!r}: {name} is given twice")
        try:
            out[name] = parse_value(rest)
        except ValueError as exc:
            raise argparse.ArgumentTypeError(f"bad --agent-kwargs {text!r}: {name}: {exc}") from None
    return tuple(sorted(out.items()))


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
    line = re.sub(r":\w+:`~?(?:[\w.]+\.)?([^`]+)`", r"\1", line).replace("``", "")
    return line + extra


def cmd_list(_: argparse.Namespace) -> int:
    print("envs:")
    for env_id in track_envs.ENV_IDS:
        entry = gym.spec(env_id).entry_point
        from gymnasium.envs.registration import load_env_creator

        creator = load_env_creator(entry) if isinstance(entry, str) else entry
        agents = [a for a in available_agents() if cells_mod.agent_applies_to_env(env_id, a)]
        print(f"  {env_id:<20} {describe(creator)}")
        print(f"  {'':<20} agents: {', '.join(agents)}")
    print("\nagents:")
    for name in available_agents():
        envs = [e for e in track_envs.ENV_IDS if cells_mod.agent_applies_to_env(e, name)]
        takes = (
            "takes --predictors" if cells_mod.agent_takes_predictor(name) else f"predictor {NO_PREDICTOR!r}"
        )
        print(f"  {name:<20} {describe(AGENTS.factory(name))}")
        print(f"  {'':<20} envs: {', '.join(envs)}; {takes}")
    print("\npredictors:")
    users = [a for a in available_agents() if cells_mod.agent_takes_predictor(a)]
    for name in available_predictors():
        envs = sorted({e for a in users for e in track_envs.ENV_IDS if cells_mod.applicable(e, a, [name])})
        print(f"  {name:<20} {describe(PREDICTORS.factory(name))}")
        print(f"  {'':<20} used by: {', '.join(users)}; envs: {', '.join(envs)}")
    print(f"\nsuites: {', '.join(cells_mod.suite_names())} (or a .toml file; see track-bench run --help)")
    return 0


def build_groups(args: argparse.Namespace) -> tuple[Group, ...]:
    """The suite named by ``--suite`` (default quick) with the other flags applied to every group."""
    groups = cells_mod.load_suite(args.suite, quick=getattr(args, "quick", False))
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


def print_skipped(command: str, skipped: Sequence[tuple[Any, str]]) -> None:
    """One warning line on stderr per file of the out dir that is not a readable record."""
    for path, reason in skipped:
        print(f"track-bench {command}: warning: skipped {path}: {reason}", file=sys.stderr)


def cmd_run(args: argparse.Namespace) -> int:
    from agents.bench.report import aggregate, terminal_table, write_report
    from agents.bench.runner import CellError, check_cells, is_finished, run_cells, scan_records

    try:
        cells = cells_mod.expand(build_groups(args))
    except (ValueError, OSError) as exc:
        print(f"track-bench run: error: {exc}", file=sys.stderr)
        return 2
    if not cells:
        print("track-bench run: error: no cell applies (check --envs / --agents)", file=sys.stderr)
        return 2
    try:
        check_cells(c for c in cells if not is_finished(Path(args.out), c))
    except CellError as exc:
        print(f"track-bench run: error: {exc} (no cell was run)", file=sys.stderr)
        return 2
    print(f"{len(cells)} cells -> {args.out} (engine {args.engine})", file=sys.stderr)
    try:
        result = run_cells(
            cells,
            args.out,
            engine=args.engine,
            workers=args.workers,
            address=args.address,
            progress=True,
            check=False,
        )
    except KeyboardInterrupt:
        print("\ninterrupted: finished cells are saved; rerun the same command to resume", file=sys.stderr)
        return 130
    except RuntimeError as exc:
        print(f"track-bench run: error: {exc}", file=sys.stderr)
        return 1
    print(
        f"{result.computed} cells computed, {result.skipped} already done, {result.wall_s:.1f} s",
        file=sys.stderr,
    )
    keys = {c.key for c in cells}
    scan = scan_records(args.out)
    print_skipped("run", scan.skipped)
    records = [r for r in scan.records if r["key"] in keys]
    write_report(records, args.out)
    print(terminal_table(aggregate(records)))
    print(f"\ntables and plots in {args.out}/ (results.md, summary.csv, records.csv, plots/)")
    return 0


def cmd_report(args: argparse.Namespace) -> int:
    from agents.bench.report import aggregate, terminal_table, write_report
    from agents.bench.runner import scan_records

    if not os.path.isdir(args.dir):
        print(f"track-bench report: error: no directory {args.dir!r}", file=sys.stderr)
        return 2
    scan = scan_records(args.dir)
    print_skipped("report", scan.skipped)
    records = scan.records
    if not records:
        print(f"track-bench report: error: no records in {args.dir!r}", file=sys.stderr)
        return 2
    t0 = time.perf_counter()
    paths = write_report(records, args.dir)
    print(terminal_table(aggregate(records)))
    skipped = f", {len(scan.skipped)} files skipped (see the warnings)" if scan.skipped else ""
    print(f"\n{len(records)} records{skipped}; wrote {len(paths)} files in {time.perf_counter() - t0:.1f} s")
    return 0


def cmd_claims(args: argparse.Namespace) -> int:
    from agents.bench.claims import claims_module
    from agents.bench.runner import scan_records

    try:
        module = claims_module(args.suite)
    except ValueError as exc:
        print(f"track-bench claims: error: {exc}", file=sys.stderr)
        return 2
    if not os.path.isdir(args.dir):
        print(f"track-bench claims: error: no directory {args.dir!r}", file=sys.stderr)
        return 2
    scan = scan_records(args.dir)
    print_skipped("claims", scan.skipped)
    if not scan.records:
        print(f"track-bench claims: error: no records in {args.dir!r}", file=sys.stderr)
        return 2
    paths = module.write_claims(scan.records, args.out, wall_s=args.wall_s, label=args.label)
    print(f"{len(scan.records)} records; wrote {', '.join(str(p) for p in paths)}")
    return 0


def _checked(kind: str, valid: Sequence[str]) -> Any:
    def parse(text: str) -> tuple[str, ...]:
        names = _names(text)
        try:
            cells_mod.check_names(kind, names, valid)
        except ValueError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None
        return names

    return parse


def build_parser() -> argparse.ArgumentParser:
    """The argparse parser of ``track-bench``."""
    fmt = argparse.RawDescriptionHelpFormatter
    parser = argparse.ArgumentParser(
        prog="track-bench",
        description="Benchmark tracker agents and predictors across the track-envs environments.",
        epilog=EPILOG,
        formatter_class=fmt,
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="{list,run,report,claims}")
    p = sub.add_parser("list", help="envs, agents and predictors, what each is and where it applies")
    p.set_defaults(func=cmd_list)
    p = sub.add_parser(
        "run",
        help="run a suite and print its table",
        epilog=SUITE_HELP + "\n\n" + EPILOG,
        formatter_class=fmt,
    )
    p.add_argument(
        "--suite",
        default="quick",
        help="quick, full, sorting, a shipped suite (pollithy2020, ...; see track-bench list) "
        "or a .toml suite file (default quick)",
    )
    p.add_argument(
        "--quick",
        action="store_true",
        help="the TOML suite's quick variant (each group's quick keys; minutes instead of an hour)",
    )
    p.add_argument("--envs", type=_checked("env", track_envs.ENV_IDS), help="comma list of env ids")
    p.add_argument("--agents", type=_checked("agent", available_agents()), help="comma list of agents")
    p.add_argument(
        "--predictors",
        type=_checked("predictor", available_predictors()),
        help="comma list of predictors (for agents that take one, e.g. gnn)",
    )
    p.add_argument("--seeds", type=parse_seeds, help="N (seeds 0..N-1), A:B (A..B-1) or a,b,c")
    p.add_argument("--episodes", type=int, help="episodes per cell (metrics: their mean)")
    p.add_argument("--steps", type=int, help="steps per episode (default: the suite's; full: env length)")
    p.add_argument(
        "--sweep",
        type=parse_sweep,
        action="append",
        metavar="NAME=V1,V2,...",
        help="sweep an env kwarg, e.g. noise_std=0,1e-4 or p_detect=0.9,0.7 (repeat for a grid)",
    )
    p.add_argument(
        "--agent-kwargs",
        type=parse_kwargs,
        metavar="NAME=V,...",
        help="make_agent keyword arguments for every cell, e.g. p_gate=0.99,max_misses=3 "
        "(gnn passes the ones it does not take to its predictor)",
    )
    p.add_argument("--workers", type=int, help="local processes (default: CPU count; 1 = in-process)")
    p.add_argument("--engine", choices=["local", "ray"], default="local", help="default local")
    p.add_argument("--address", help="Ray cluster address for --engine ray (e.g. auto, ray://host:10001)")
    p.add_argument("--out", default="results/bench", help="directory of the records (default results/bench)")
    p.set_defaults(func=cmd_run)
    p = sub.add_parser("report", help="rebuild tables and plots from the records in DIR")
    p.add_argument("dir", metavar="DIR")
    p.set_defaults(func=cmd_report)
    p = sub.add_parser(
        "claims",
        help="a paper's figures and claims table from the records of its suite in DIR",
        epilog="example: track-bench claims pollithy2020 results/pollithy2020 --out docs",
    )
    p.add_argument("suite", metavar="SUITE", help="a suite with a claims table (pollithy2020, ...)")
    p.add_argument("dir", metavar="DIR", help="the records of track-bench run --suite SUITE")
    p.add_argument("--out", default="docs", help="writes OUT/SUITE.md and OUT/figures/SUITE/ (default docs)")
    p.add_argument("--wall-s", type=float, help="wall time of the run in seconds, stated in the table")
    p.add_argument("--label", default="", help="text appended to the title (e.g. ' (quick run)')")
    p.set_defaults(func=cmd_claims)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``track-bench`` console script."""
    args = build_parser().parse_args(argv)
    return int(args.func(args))


if __name__ == "__main__":
    sys.exit(main())
