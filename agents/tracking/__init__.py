"""The multi-target point tracker and what its trackers share: the core
(`.tracker`: track table, life cycle, velocity prior, report), the association
components (`.associator`: the protocol and registry;
`.gated`, `.second_chance`,
`.merges`), gating and assignment (the sorting roll-out to the nozzle bar is
[`agents.sorting`][agents.sorting])."""

from agents.tracking.assign import chi2_gate, mahalanobis_cost
from agents.tracking.associator import (
    Association,
    Associator,
    AssociatorCapability,
    FrameContext,
    associator_capability,
    available_associators,
    hard_update,
    make_associator,
    register_associator,
)
from agents.tracking.gated import GatedAssignment
from agents.tracking.merges import SharedBlobs
from agents.tracking.second_chance import SecondChance
from agents.tracking.tracker import PointTracker
from agents.tracking.velocity_prior import VelocityPriorState
from track_envs.infra.lazy import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(__name__, __file__)
