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

__getattr__, __dir__, __all__ = lazy_exports(__name__, __file__)
