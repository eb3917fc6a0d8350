"""The ``track`` command: ``track bench|run|train|tune|list ...``.

One console script with a subcommand per job; each subcommand's parser lives in its own module of
this package and reads its shared flags from `track_apps.cli.arguments`.
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Callable, Sequence

__all__ = ["build_parser", "main"]


def _bench(argv: Sequence[str] | None, prog: str = "track bench") -> int:
    from track_apps.cli.bench import main

    return main(argv, prog)


def _run(argv: Sequence[str] | None, prog: str = "track run") -> int:
    from track_apps.cli.run import main

    return main(argv, prog)


def _train(argv: Sequence[str] | None, prog: str = "track train") -> int:
    try:
        from track_apps.cli.train import main

        return main(argv, prog)
    except ModuleNotFoundError as exc:
        if exc.name != "torch":
            raise
        print(f'{prog}: error: training needs torch: pip install "track-envs[torch]"', file=sys.stderr)
        return 2


def _tune(argv: Sequence[str] | None, prog: str = "track tune") -> int:
    from track_apps.cli.tune import main

    return main(argv, prog)


def _list(argv: Sequence[str] | None, prog: str = "track list") -> int:
    from track_apps.cli.bench import list_main

    return list_main(argv, prog)


#: Subcommand → (entry point taking the arguments after the subcommand, one-line summary).
COMMANDS: dict[str, tuple[Callable[..., int], str]] = {
    "bench": (_bench, "benchmark agents and predictors over the envs (suites, records, tables)"),
    "run": (_run, "track a detection file with any agent; write the tracks, score them"),
    "train": (_train, "train a learned motion model (belt LSTMs, displacement LSTM, pose LSTM)"),
    "tune": (_tune, "PPO gate tuning on GateTuning-v0: train, grid baseline, paired evaluation"),
    "list": (_list, "envs, agents and predictors, what each is and where it applies"),
}


EPILOG = """\
examples:
  track list
  track bench run --suite quick --out results/quick
  track run det.txt --agent gnn --predictor kf-ca --dt 0.04 --out tracks.txt
  track train nll-lstm --env BeltSorter-v0 --env-kwargs particle_kind=cylinder --out models/nll
  track tune evaluate --seeds 20 --best-fixed results/gate_grid

Run 'track COMMAND --help' for a command's options and examples.

NAME=VALUE arguments (--env-kwargs, --agent-kwargs, --fixed, --sweep) are comma-separated:
  particle_kind=sphere,noise_std=1e-4,merge_touching=false,label='a b',sizes=[1,2]
A value is a number, true/false, none, a bare name or path, a 'quoted string' or a [list];
anything else is an error naming it.
Noise: --declared-noise-std is what the tracker is told (its R; track run), --added-noise-std is
noise added to the data (track train).
--out: each command's help says whether it is a file, a path without suffix or a directory.
"""


def build_parser() -> argparse.ArgumentParser:
    """The top-level parser: ``track COMMAND ...`` (each command parses its own arguments)."""
    parser = argparse.ArgumentParser(
        prog="track",
        description="Tracking envs, tracker agents and predictors: one command, one subcommand per job.",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name, (_, summary) in COMMANDS.items():
        sub.add_parser(name, help=summary, add_help=False)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``track`` console script."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv and argv[0] in COMMANDS:
        try:
            return int(COMMANDS[argv[0]][0](argv[1:]))
        except BrokenPipeError:  # the reader of a pipe closed it (``track list | head``): not an error
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())  # no second error at exit
            return 0
    build_parser().parse_args(argv)  # prints the usage (or help) and exits
    return 2
