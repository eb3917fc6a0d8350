"""The ``track`` command: ``track bench|run|train|tune|list ...``.

One console script with a subcommand per job; each subcommand's parser lives in its own module of
this package and reads its shared flags from :mod:`agents.cli.arguments`. The four older script
names are aliases of the same parsers for this release: ``track-bench ARGS`` is ``track bench
ARGS``, and so on (:func:`bench_alias`, :func:`run_alias`, :func:`train_alias`, :func:`tune_alias`).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence


def _bench(argv: Sequence[str] | None) -> int:
    from agents.bench.cli import main

    return main(argv)


def _run(argv: Sequence[str] | None) -> int:
    from agents.run_cli import main

    return main(argv)


def _train(argv: Sequence[str] | None) -> int:
    from agents.train import main

    return main(argv)


def _tune(argv: Sequence[str] | None) -> int:
    from agents.tuning.cli import main

    return main(list(argv) if argv is not None else None)


def _list(argv: Sequence[str] | None) -> int:
    from agents.bench.cli import main

    return main(["list", *(argv or [])])


#: Subcommand → (entry point taking the arguments after the subcommand, one-line summary).
COMMANDS: dict[str, tuple[Callable[[Sequence[str] | None], int], str]] = {
    "bench": (_bench, "benchmark agents and predictors over the envs (suites, records, tables)"),
    "run": (_run, "track a detection file with any agent; write the tracks, score them"),
    "train": (_train, "train a learned motion model (belt LSTMs, displacement LSTM, pose LSTM)"),
    "tune": (_tune, "PPO gate tuning on GateTuning-v0: train, grid baseline, paired evaluation"),
    "list": (_list, "envs, agents and predictors, what each is and where it applies"),
}


def build_parser() -> argparse.ArgumentParser:
    """The top-level parser: ``track COMMAND ...`` (each command parses its own arguments)."""
    parser = argparse.ArgumentParser(
        prog="track",
        description="Tracking envs, tracker agents and predictors: one command, one subcommand per job.",
        epilog="Run 'track COMMAND --help' for a command's options and examples. The older names "
        "track-bench, track-run, track-train and track-tune still work as aliases of "
        "track bench, track run, track train and track tune.",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name, (_, summary) in COMMANDS.items():
        sub.add_parser(name, help=summary, add_help=False)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``track`` console script."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv and argv[0] in COMMANDS:
        return int(COMMANDS[argv[0]][0](argv[1:]))
    build_parser().parse_args(argv)  # prints the usage (or help) and exits
    return 2


def bench_alias() -> int:
    """``track-bench``: an alias of ``track bench`` for this release."""
    return _bench(None)


def run_alias() -> int:
    """``track-run``: an alias of ``track run`` for this release."""
    return _run(None)


def train_alias() -> int:
    """``track-train``: an alias of ``track train`` for this release."""
    return _train(None)


def tune_alias() -> int:
    """``track-tune``: an alias of ``track tune`` for this release."""
    return _tune(None)
