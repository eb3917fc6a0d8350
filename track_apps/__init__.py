"""The applications of the tracker libraries: what a command runs, beside what a script imports.

The libraries ([`track_envs`][track_envs], [`predictors`][predictors], [`agents`][agents]) are what a user
imports in a script; this package holds the programs built on them, as a model zoo sits beside its learning
library, and none of the libraries imports it:

* [`track_apps.cli`][track_apps.cli] — the ``track`` command (``track bench|run|train|tune|list``);
* [`track_apps.bench`][track_apps.bench] — the benchmark runner, its suites, tables, figures and claims;
* [`track_apps.tuning`][track_apps.tuning] — GateTuning-v0, its PPO training and evaluation, the shipped
policy;
* `track_apps.reproductions` — the paper reproductions that run the trackers;
* `track_apps.lstm_line_search` — the post-training covariance line search of
``track train
  lstm``.
"""

__all__: list[str] = []
