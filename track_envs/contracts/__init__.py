"""The environment <-> agent contracts: the observation, the report (the action) and its optional
sorting channel, with their spaces, builders and validators."""

from __future__ import annotations

from typing import TYPE_CHECKING

from track_envs.infra.lazy import lazy_exports

if TYPE_CHECKING:
    from track_envs.contracts.observation import OBSERVATION_KEYS, check_observation, pack_observation
    from track_envs.contracts.report import (
        ID_LIMIT,
        REPORT_KEYS,
        Report,
        ReportOverflowError,
        ReportSpace,
        empty_report,
        pack_report,
        report_space,
        validate_report,
    )
    from track_envs.contracts.sorting_channel import (
        SORTING_KEYS,
        SortingPredictions,
        empty_sorting,
        pack_sorting,
        validate_sorting,
    )

#: The module of each name loaded on first access (``__getattr__``), so that importing
#: the package stays light.
_LAZY: dict[str, str] = {
    "OBSERVATION_KEYS": "track_envs.contracts.observation",
    "check_observation": "track_envs.contracts.observation",
    "pack_observation": "track_envs.contracts.observation",
    "ID_LIMIT": "track_envs.contracts.report",
    "REPORT_KEYS": "track_envs.contracts.report",
    "Report": "track_envs.contracts.report",
    "ReportOverflowError": "track_envs.contracts.report",
    "ReportSpace": "track_envs.contracts.report",
    "empty_report": "track_envs.contracts.report",
    "pack_report": "track_envs.contracts.report",
    "report_space": "track_envs.contracts.report",
    "validate_report": "track_envs.contracts.report",
    "SORTING_KEYS": "track_envs.contracts.sorting_channel",
    "SortingPredictions": "track_envs.contracts.sorting_channel",
    "empty_sorting": "track_envs.contracts.sorting_channel",
    "pack_sorting": "track_envs.contracts.sorting_channel",
    "validate_sorting": "track_envs.contracts.sorting_channel",
}

__all__ = [
    "ID_LIMIT",
    "OBSERVATION_KEYS",
    "REPORT_KEYS",
    "SORTING_KEYS",
    "Report",
    "ReportOverflowError",
    "ReportSpace",
    "SortingPredictions",
    "check_observation",
    "empty_report",
    "empty_sorting",
    "pack_observation",
    "pack_report",
    "pack_sorting",
    "report_space",
    "validate_report",
    "validate_sorting",
]


__getattr__, __dir__ = lazy_exports(__name__, _LAZY, __all__)
