"""Top-down 2-D physics of an optical belt sorter (pymunk), with batched I/O.

Coordinates: ``x`` along the belt (transport direction), ``y`` across it, in metres; the camera
window spans ``0 <= x <= window_length`` and ``0 <= y <= window_width``; side walls run along
``y = 0`` and ``y = window_width`` over the whole belt.

Belt friction is Coulomb sliding friction between each particle and the belt. With slip
velocity ``u = v − (v_belt, 0)`` a particle of kind ``k`` decelerates relative to the belt at
``μ_k g`` along ``−u/|u|`` until the slip vanishes, so over one step ``h``

.. math::

    u \\leftarrow u \\, \\max\\big(0, 1 − μ_k g h / |u|\\big),

and its spin decays likewise, ``|ω| \\leftarrow \\max(0, |ω| − μ_k g h / r_k)``. This update is applied
to all particles at once in compiled code ([`track_envs.envs.belt_kernels`][track_envs.envs.belt_kernels])
through pymunk's batch API (``pymunk.batch``); collisions between particles and with the walls are resolved by
pymunk.

The space moves with the belt: pymunk simulates in the belt's rest frame, where the walls (one
kinematic body) slide upstream at ``−v_belt`` and a particle's velocity is its slip over the belt.
The physics is the same as in the ground frame (Galilean invariance; wall friction acts on the
relative velocity either way), but particles that have caught up with the belt are nearly at rest,
so pymunk's velocity-swept bounding boxes stay tight and the broad phase does less work. Every
state the world hands out is in the ground frame: ``x = x_belt + s(t)``, ``v_x = v_x,belt + v_belt``
with the belt's travel ``s(t) = v_belt t``.

No per-body Python runs in a frame: a frame is one batch write, one ``Space.step`` and one
batch read per substep, with the belt friction, births and deaths computed in compiled kernels. A particle
that leaves past the belt end parks its body far from the belt (a row write), and a landing
particle takes a parked body of its kind (another row write), so pymunk's body order stays
fixed. Only when a burst needs more bodies than are parked, or too many are parked, are bodies
added to or removed from the space (Python once per body, then one re-labelling of the rows).

A world cannot be pickled or deep-copied: a copied pymunk ``Space`` keeps its bodies and cached
contacts but not its broad-phase tree and solver order, so it would drift from the original.
[`BeltSorterEnv`][track_envs.envs.BeltSorterEnv] rebuilds its world exactly by replay instead;
[`BeltWorld.digest`][track_envs.envs.belt_physics.BeltWorld.digest] lets it check the rebuilt world against
the original.
"""

from __future__ import annotations

import hashlib
import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import pymunk
import pymunk.batch as pb
from numpy.typing import NDArray

from track_envs.envs.belt_kernels import (
    NOT_PARTICLE,
    PARK_ORIGIN,
    PARKED,
    belt_friction,
    land,
    line_crossings,
    park_exits,
    park_row,
    window_state,
)
from track_envs.infra.arguments import check_int, check_non_negative, check_number, check_positive

GRAVITY = 9.81
#: Rounding radius (m) of the box collision shapes (cylinders, cuboids): contact happens at this
#: distance from the nominal box.
BOX_ROUNDING = 0.0005
_STATE_FIELDS = (
    pb.BodyFields.POSITION | pb.BodyFields.ANGLE | pb.BodyFields.VELOCITY | pb.BodyFields.ANGULAR_VELOCITY
)
_READ_FIELDS = pb.BodyFields.BODY_ID | _STATE_FIELDS
_WRITE_FIELDS = pb.BodyFields.VELOCITY | pb.BodyFields.ANGULAR_VELOCITY
# Columns of one row of the batch buffer for _STATE_FIELDS.
_X, _Y, _ANGLE, _VX, _VY, _SPIN = range(6)


@dataclass(frozen=True)
class ParticleKind:
    """Material and shape of one kind of bulk particle, seen from above.

    Attributes:
        name: Kind name.
        shape: ``"circle"`` (spheres) or ``"box"`` (cylinders lying flat, cuboids).
        length: Extent along the particle's own axis in metres (the diameter for circles).
        width: Extent across it in metres (equal to ``length`` for circles).
        density: Material density in kg/m³ (mass from the 3-D volume).
        belt_friction: Coulomb friction coefficient μ between particle and belt.
        particle_friction: pymunk friction of particle–particle and particle–wall contacts.
        restitution: pymunk elasticity of contacts.
        chute_speed: Mean along-belt speed (m/s) with which particles land on the belt.
        chute_speed_std: Spread of that speed (m/s).
        lateral_speed_std: Spread of the lateral landing speed (m/s).
        angle_std: Spread of the landing orientation about the belt axis (rad).
        height: Third dimension in metres, only for the mass.
    """

    name: str
    shape: str
    length: float
    width: float
    density: float
    belt_friction: float
    particle_friction: float
    restitution: float
    chute_speed: float
    chute_speed_std: float
    lateral_speed_std: float
    angle_std: float
    height: float

    @property
    def mass(self) -> float:
        """Mass in kg from the 3-D volume (sphere, cylinder of diameter ``width``, or cuboid)."""
        if self.shape == "circle":
            volume = np.pi / 6 * self.length**3
        elif self.name == "cylinder":
            volume = np.pi / 4 * self.width**2 * self.length
        else:
            volume = self.length * self.width * self.height
        return float(self.density * volume)

    @property
    def radius(self) -> float:
        """Radius of gyration scale used for the spin decay, in metres."""
        return 0.5 * max(self.length, self.width)


#: Calibrated kinds. Sizes and densities are those of the authors' DEM particles' scale (few mm,
#: plastic-like); μ_k g ≈ 1.57 m/s² gives the measured median acceleration on the belt.
PARTICLE_KINDS: dict[str, ParticleKind] = {
    "sphere": ParticleKind(
        name="sphere",
        shape="circle",
        length=0.005,
        width=0.005,
        density=1150.0,
        belt_friction=0.16,
        particle_friction=0.3,
        restitution=0.5,
        chute_speed=0.99,
        chute_speed_std=0.06,
        lateral_speed_std=0.065,
        angle_std=0.0,
        height=0.005,
    ),
    "cylinder": ParticleKind(
        name="cylinder",
        shape="box",
        length=0.010,
        width=0.005,
        density=1150.0,
        belt_friction=0.16,
        particle_friction=0.5,
        restitution=0.3,
        chute_speed=0.85,
        chute_speed_std=0.06,
        lateral_speed_std=0.07,
        angle_std=0.3,
        height=0.005,
    ),
    "cuboid": ParticleKind(
        name="cuboid",
        shape="box",
        length=0.008,
        width=0.006,
        density=1150.0,
        belt_friction=0.16,
        particle_friction=0.6,
        restitution=0.2,
        chute_speed=0.85,
        chute_speed_std=0.06,
        lateral_speed_std=0.07,
        angle_std=0.6,
        height=0.004,
    ),
}


def resolve_mixture(particle_kind: str | Mapping[str, float]) -> dict[str, float]:
    """Normalised kind proportions from a kind name, ``"mixture"`` (equal thirds) or a mapping.

    Raises:
        ValueError: for an unknown kind name or non-positive total weight.
    """
    if isinstance(particle_kind, str):
        if particle_kind == "mixture":
            return {k: 1.0 / len(PARTICLE_KINDS) for k in PARTICLE_KINDS}
        if particle_kind not in PARTICLE_KINDS:
            raise ValueError(
                f"particle_kind must be one of {[*PARTICLE_KINDS, 'mixture']} or a mapping of them to "
                f"weights, got {particle_kind!r}"
            )
        return {particle_kind: 1.0}
    weights = dict(particle_kind)
    unknown = [k for k in weights if k not in PARTICLE_KINDS]
    if unknown:
        raise ValueError(f"particle_kind has unknown kinds {unknown}; valid kinds are {list(PARTICLE_KINDS)}")
    for kind, weight in weights.items():
        check_non_negative(f"particle_kind[{kind!r}]", weight)
    if sum(weights.values()) <= 0:
        raise ValueError(f"particle_kind weights must be >= 0 with a positive sum, got {weights}")
    total = sum(weights.values())
    return {k: w / total for k, w in weights.items() if w > 0}


@dataclass(frozen=True)
class BeltParams:
    """Geometry and operating point of the belt (defaults calibrated to the DEM figures).

    Attributes:
        window_length: Camera window along the belt (m).
        window_width: Belt width between the side walls (m), also the window's width.
        belt_speed: Belt speed (m/s).
        feed_rate: Mean number of particles dropped per second.
        feed_burstiness: Standard deviation σ of the log feed intensity (bursty feed).
        feed_correlation_time: Correlation time of the feed intensity (s).
        drop_x: Along-belt position where particles land (m, negative: upstream of the window).
        drop_spread: Along-belt spread of the landing positions (m).
        exit_margin: Particles are removed this far past the window end (m).
        warmup_time: Simulated time before the first frame, so the belt is in steady state (s).
        substeps: Physics steps per camera frame.
    """

    window_length: float = 0.40
    window_width: float = 0.18
    belt_speed: float = 1.44
    feed_rate: float = 195.0
    feed_burstiness: float = 0.55
    feed_correlation_time: float = 0.2
    drop_x: float = -0.08
    drop_spread: float = 0.04
    exit_margin: float = 0.02
    warmup_time: float = 1.0
    substeps: int = 1

    def __post_init__(self) -> None:
        for name in ("window_length", "window_width", "belt_speed", "feed_correlation_time"):
            check_positive(name, getattr(self, name))
        for name in ("feed_rate", "feed_burstiness", "drop_spread", "exit_margin", "warmup_time"):
            check_non_negative(name, getattr(self, name))
        if not check_number("drop_x", self.drop_x) < 0:
            raise ValueError(f"drop_x must be upstream of the window (< 0 m), got {self.drop_x!r}")
        check_int("substeps", self.substeps, 1, 20)

    @classmethod
    def industrial(cls, **changes: float) -> BeltParams:
        """An industrial-width belt: 2 m wide, a 4 m camera window, ≈12,000 particles in view.

        The default belt's material and speeds on a belt eleven times as wide, seen over a ten
        times longer window: ``window_width = 2.0`` m, ``window_length = 4.0`` m, ``feed_rate =
        {feed:,}`` /s (twice the default's feed per metre of width: ≈2,100 cylinders per m² at belt
        speed, about 10 % of the belt covered), so that
        `expected_in_view` gives ≈12,000 cylinders in the
        window (≥ 10,000 in every frame of a 1,500-frame episode). A feeder 2 m wide acts as eleven
        independent 0.18 m ones, so the feed's bursts average out:
        ``feed_burstiness = 0.55 / √11 ≈ 0.17``. ``warmup_time = 3.5`` s fills the belt up to the
        nozzle bar before the first frame. Every other field keeps its default; ``changes``
        overrides any field (``BeltParams.industrial(feed_rate=6000.0)``).
        """
        preset: dict[str, float] = {
            "window_length": 4.0,
            "window_width": 2.0,
            "feed_rate": INDUSTRIAL_FEED_RATE,
            "feed_burstiness": 0.17,
            "warmup_time": 3.5,
        }
        preset.update(changes)
        return cls(**preset)  # type: ignore[arg-type]


#: The feed rate (particles/s) of [`BeltParams.industrial`][track_envs.envs.BeltParams.industrial].
INDUSTRIAL_FEED_RATE = 4300.0

#: The belts a name stands for (``gym.make("BeltSorter-v0", physics="industrial")``, a suite's
#: ``env_kwargs = { physics = "industrial" }``).
BELT_PRESETS = ("default", "industrial")


def belt_preset(name: str) -> BeltParams:
    """The [`BeltParams`][track_envs.envs.BeltParams] of a preset name in
    [`BELT_PRESETS`][track_envs.envs.belt_physics.BELT_PRESETS].

    Raises:
        ValueError: naming the unknown preset and the valid names.
    """
    if name == "default":
        return BeltParams()
    if name == "industrial":
        return BeltParams.industrial()
    raise ValueError(f"physics preset must be one of {list(BELT_PRESETS)} or a BeltParams, got {name!r}")


def window_residence(params: BeltParams, kind: ParticleKind) -> float:
    """Mean time (s) a particle of ``kind`` spends in the camera window, from the belt's kinematics.

    A particle lands at ``x₀ = drop_x − drop_spread / 2`` with the chute's speed ``v₀`` and slides
    toward belt speed ``v_b`` at ``a = μ g`` until it reaches it (``t_r = |v_b − v₀| / a``, over
    ``x_r = (v₀ + v_b) t_r / 2``), then rides with the belt:

    .. math::

        x(t) = x₀ + v₀ t ± a t^2 / 2 \\; (t \\le t_r), \\qquad
        x(t) = x₀ + x_r + v_b (t − t_r) \\; (t > t_r),

    and the residence is ``t(window_length) − t(0)``. Collisions are left out (on the default belt
    this gives 61 particles in view at the default feed; the episodes average 58–73).
    """
    v0, vb, a = kind.chute_speed, params.belt_speed, kind.belt_friction * GRAVITY
    x0 = params.drop_x - 0.5 * params.drop_spread
    t_r = abs(vb - v0) / a
    x_r = 0.5 * (v0 + vb) * t_r
    sign = 1.0 if vb >= v0 else -1.0

    def time_to(x: float) -> float:
        dx = x - x0
        if dx > x_r:
            return t_r + (dx - x_r) / vb
        if sign > 0:
            return (-v0 + math.sqrt(v0 * v0 + 2.0 * a * dx)) / a
        return (v0 - math.sqrt(max(v0 * v0 - 2.0 * a * dx, 0.0))) / a

    return time_to(params.window_length) - time_to(0.0)


def expected_in_view(params: BeltParams, kinds: Mapping[str, float]) -> float:
    """Mean number of particles in the camera window: ``feed_rate · Σ_k w_k T_k`` with the kind
    weights ``w_k`` ([`resolve_mixture`][track_envs.envs.belt_physics.resolve_mixture]) and residences ``T_k``
    ([`window_residence`][track_envs.envs.belt_physics.window_residence])."""
    return params.feed_rate * sum(w * window_residence(params, PARTICLE_KINDS[k]) for k, w in kinds.items())


#: Observation rows never derived below this (the default belt's rows before they were derived).
MIN_ROWS = 256


def scene_rows(params: BeltParams, kinds: Mapping[str, float]) -> int:
    """Rows that hold every particle of the window in a burst: ``max_detections``, ``max_tracks``
    and ``max_targets`` when not given.

    With ``N̄`` particles in view on average
    ([`expected_in_view`][track_envs.envs.belt_physics.expected_in_view]) and feed burstiness ``σ``, a burst
    brings ``N̄ e^{2σ}`` (the feed intensity two standard deviations up), and the Poisson count ``4 √·`` more;
    the rows are that rounded up to a multiple of 256, at least
    [`MIN_ROWS`][track_envs.envs.belt_physics.MIN_ROWS]. The default belt: ``N̄ = 61``, 247 → 256 rows (its
    peaks are 140–210); [`BeltParams.industrial`][track_envs.envs.BeltParams.industrial]: ``N̄ ≈ 12,000``,
    ``≈ 17,000`` rows.
    """
    burst = expected_in_view(params, kinds) * math.exp(2.0 * params.feed_burstiness)
    need = burst + 4.0 * math.sqrt(burst)
    return max(MIN_ROWS, 256 * math.ceil(need / 256))


@dataclass
class BeltState:
    """Every particle on the belt (arrays of length n), ordered by truth id.

    Attributes:
        ids: Truth ids (int64), unique over an episode, in order of landing.
        position: (n, 2) centroids in metres.
        velocity: (n, 2) velocities in m/s.
        angle: (n,) orientations in rad.
        kind: (n,) index into the world's kind list.
    """

    ids: NDArray[np.int64]
    position: NDArray[np.float64]
    velocity: NDArray[np.float64]
    angle: NDArray[np.float64]
    kind: NDArray[np.int64]


Handles = tuple[pymunk.Body, pymunk.Shape]


def parking_room(feed_rate: float, dt: float) -> int:
    """Parked bodies a world keeps: ``max(128, 8 · feed_rate · dt)``, eight frames of landings.

    Landings take parked bodies and exits park them; only when a kind runs short or more than this
    many are parked are bodies added to or removed from the space (Python per body, then a
    re-labelling of every row), so the room grows with the feed to keep that rare.
    """
    return max(128, math.ceil(8.0 * feed_rate * dt))


_NO_CROSSINGS = (np.zeros(0, dtype=np.int64), np.zeros(0), np.zeros(0))


class BeltWorld:
    """The pymunk world of the belt: particle bodies, side walls, feed, belt friction.

    Rows: ``_rows`` (m, 6) holds every body of the space in pymunk's iteration order (x, y,
    angle, vx, vy, spin) in the belt's rest frame, and ``_row_truth`` labels each row with the
    truth id of the particle on it, [`PARKED`][track_envs.envs.belt_physics.PARKED] for a parked body or
    [`NOT_PARTICLE`][track_envs.envs.belt_physics.NOT_PARTICLE] for the kinematic wall body; ``_row_kind``
    gives the kind of each particle body. ``travel`` is the belt's travel ``s(t)`` that maps belt-frame to
    ground-frame positions.

    Args:
        params: Geometry and operating point.
        kinds: Kind proportions, from [`resolve_mixture`][track_envs.envs.belt_physics.resolve_mixture].
        rng: Generator for every random draw (landing times, places, speeds, kinds).
        dt: Camera frame period (s); each [`step`][track_envs.envs.belt_physics.BeltWorld.step] advances this
            much.
        max_parked: Parked bodies kept in the space before the surplus is removed; default
            [`parking_room`][track_envs.envs.belt_physics.parking_room] of the feed (128 up to 16 landings per
            frame, eight frames of landings above), so that a busy belt does not add and remove bodies every
            few frames.
        line_x: Ground-frame ``x`` of a line across the belt (the nozzle bar of a sorter) whose
            crossings [`step`][track_envs.envs.belt_physics.BeltWorld.step] records in `crossings`, or
            ``None``. Particles stay on the belt until they are past it: the belt end (where particles are
            removed) is ``max(window_length + exit_margin, line_x)``.
    """

    def __init__(
        self,
        params: BeltParams,
        kinds: Mapping[str, float],
        rng: np.random.Generator,
        dt: float,
        max_parked: int | None = None,
        line_x: float | None = None,
    ):
        self.params = params
        self.line_x = None if line_x is None else float(line_x)
        self.belt_end = params.window_length + params.exit_margin
        if self.line_x is not None:
            self.belt_end = max(self.belt_end, self.line_x)
        #: The line crossings of the last [`step`][track_envs.envs.belt_physics.BeltWorld.step]: truth ids
        #: (k,), the fraction of the frame
        #: period at which each particle crossed (k,) in (0, 1], its lateral position ``y`` (k,).
        self.crossings: tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.float64]] = _NO_CROSSINGS
        self.kind_names = list(kinds)
        self.kind_weights = np.array([kinds[k] for k in self.kind_names])
        self.kinds = [PARTICLE_KINDS[k] for k in self.kind_names]
        self.rng = rng
        self.dt = dt
        self.time = 0.0
        self.travel = 0.0
        self.max_parked = parking_room(params.feed_rate, dt) if max_parked is None else max_parked
        self._decel = np.array([k.belt_friction * GRAVITY for k in self.kinds])
        self._spin_decel = np.array([k.belt_friction * GRAVITY / k.radius for k in self.kinds])
        self._landing = np.array(
            [[k.chute_speed, k.chute_speed_std, k.lateral_speed_std, k.angle_std] for k in self.kinds]
        )
        self._half_size = np.array([0.5 * max(k.length, k.width) for k in self.kinds])
        self._next_id = 0
        self._feed_log_intensity = 0.0
        self._build_space()

    # -- construction -------------------------------------------------------------------------
    def _build_space(self) -> None:
        p = self.params
        space = pymunk.Space()
        space.gravity = (0.0, 0.0)
        space.iterations = 5
        space.collision_slop = 5e-5
        space.collision_bias = 1e-9
        space.sleep_time_threshold = float("inf")
        # The walls are fixed to the ground, so in the belt's rest frame they slide upstream.
        walls = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
        walls.velocity = (-p.belt_speed, 0.0)
        space.add(walls)
        thickness = 0.01
        x0 = p.drop_x - p.drop_spread - 0.05
        x1 = max(p.window_length + p.exit_margin + 0.05, self.belt_end + 0.02)
        for y in (-thickness, p.window_width + thickness):
            wall = pymunk.Segment(walls, (x0, y), (x1, y), thickness)
            wall.friction = 0.3
            wall.elasticity = 0.3
            space.add(wall)
        self.space = space
        self._pool: list[list[Handles]] = [[] for _ in self.kinds]  # bodies out of the space
        self._handles: dict[int, tuple[pymunk.Body, pymunk.Shape, int]] = {}  # pointer -> body, shape, kind
        self._buf = pb.Buffer()
        self._set_buf = pb.Buffer()
        self._row_ptr = np.zeros(0, dtype=np.uint64)
        self._row_truth = np.zeros(0, dtype=np.int64)
        self._row_kind = np.zeros(0, dtype=np.int64)
        self._rows = np.zeros((0, 6))
        self._relabel()

    def _new_body(self, kind_index: int) -> Handles:
        """Construct one body of a kind (only when the pool of that kind is empty)."""
        kind = self.kinds[kind_index]
        mass = kind.mass
        if kind.shape == "circle":
            body = pymunk.Body(mass, pymunk.moment_for_circle(mass, 0.0, 0.5 * kind.length))
            shape: pymunk.Shape = pymunk.Circle(body, 0.5 * kind.length)
        else:
            body = pymunk.Body(mass, pymunk.moment_for_box(mass, (kind.length, kind.width)))
            shape = pymunk.Poly.create_box(body, (kind.length, kind.width), radius=BOX_ROUNDING)
        shape.friction = kind.particle_friction
        shape.elasticity = kind.restitution
        return body, shape

    # -- pickling -----------------------------------------------------------------------------
    def __getstate__(self) -> dict:
        raise TypeError(
            "a BeltWorld cannot be pickled or deep-copied: pymunk does not expose its broad-phase tree "
            "and the order of its contact solver, so a restored space would drift from the original "
            "within a frame; pickle or deep-copy the BeltSorterEnv instead, which rebuilds its world "
            "exactly by replaying the episode from its start"
        )

    def digest(self) -> bytes:
        """A 16-byte fingerprint of the world's state: every body's row, the row labels, the belt's
        travel and clock, the feed's intensity and the next truth id (equal digests: the same
        state, bit for bit, as far as the rows show it)."""
        h = hashlib.blake2b(digest_size=16)
        for array in (self._rows, self._row_truth, self._row_kind):
            h.update(np.ascontiguousarray(array).tobytes())
        scalars = (self.travel, self.time, self._feed_log_intensity)
        h.update(np.array(scalars, dtype=np.float64).tobytes())
        h.update(np.array([self._next_id, self._n_parked, len(self._rows)], dtype=np.int64).tobytes())
        return h.digest()

    # -- batch I/O ----------------------------------------------------------------------------
    def _read(self) -> None:
        """Batch-read the state of every body (rows keep their labels: the order is unchanged)."""
        self._buf.clear()
        pb.get_space_bodies(self.space, _STATE_FIELDS, self._buf)
        self._rows = np.frombuffer(self._buf.float_buf(), dtype=np.float64).reshape(-1, 6).copy()

    def _relabel(self) -> None:
        """After bodies were added or removed: take pymunk's new order, carry rows over by pointer.

        ``_rows`` stays authoritative (it may hold landings not yet written); the wall body
        takes its state from pymunk, bodies new to the space are parked.
        """
        old_ptr, old_truth, old_rows = self._row_ptr, self._row_truth, self._rows
        self._buf.clear()
        pb.get_space_bodies(self.space, _READ_FIELDS, self._buf)
        ptrs = np.frombuffer(self._buf.int_buf(), dtype=np.uint64).copy()
        current = np.frombuffer(self._buf.float_buf(), dtype=np.float64).reshape(-1, 6)
        table_ptr, table_kind = self._body_table
        at = np.minimum(np.searchsorted(table_ptr, ptrs), max(len(table_ptr) - 1, 0))
        particle = table_ptr[at] == ptrs if len(table_ptr) else np.zeros(len(ptrs), dtype=bool)
        self._row_kind = np.where(particle, table_kind[at] if len(table_ptr) else 0, 0)
        self._rows = current.copy()
        self._row_truth = np.where(particle, PARKED, NOT_PARTICLE)
        if len(old_ptr):
            order = np.argsort(old_ptr)
            at = order[np.minimum(np.searchsorted(old_ptr[order], ptrs), len(old_ptr) - 1)]
            known = old_ptr[at] == ptrs
            self._rows[known] = old_rows[at[known]]
            self._row_truth[known] = old_truth[at[known]]
        self._row_ptr = ptrs
        parked = np.flatnonzero(self._row_truth == PARKED)
        for r in parked.tolist():
            park_row(self._rows, self._row_truth, r)
        self._n_parked = len(parked)

    @property
    def _body_table(self) -> tuple[NDArray[np.uint64], NDArray[np.int64]]:
        """Pointers (sorted) and kinds of the particle bodies in the space."""
        ptr = np.fromiter(self._handles, dtype=np.uint64, count=len(self._handles))
        kind = np.fromiter((h[2] for h in self._handles.values()), dtype=np.int64, count=len(self._handles))
        order = np.argsort(ptr)
        return ptr[order], kind[order]

    def _write(self, poses: bool = False) -> None:
        """Batch-write velocities and spins, and with ``poses`` positions and angles too."""
        if poses:
            self._set_buf.set_float_buf(self._rows.reshape(-1))
            pb.set_space_bodies(self.space, _STATE_FIELDS, self._set_buf)
        else:
            self._set_buf.set_float_buf(np.ascontiguousarray(self._rows[:, _VX:]).reshape(-1))
            pb.set_space_bodies(self.space, _WRITE_FIELDS, self._set_buf)

    # -- parking, births and deaths -----------------------------------------------------------
    def _add_bodies(self, kind_index: int, count: int) -> None:
        """Put ``count`` more bodies of a kind into the space, parked (Python per body; rare)."""
        for _ in range(count):
            body, shape = (
                self._pool[kind_index].pop() if self._pool[kind_index] else self._new_body(kind_index)
            )
            body.position = (2 * PARK_ORIGIN, 2 * PARK_ORIGIN)
            self.space.add(body, shape)
            self._handles[body.id] = (body, shape, kind_index)
        self._relabel()

    def _trim_parking(self) -> None:
        """Above ``max_parked`` parked bodies, take half of them out of the space (Python per body; rare)."""
        if self._n_parked <= self.max_parked:
            return
        parked = np.flatnonzero(self._row_truth == PARKED)
        for ptr in self._row_ptr[parked[self.max_parked // 2 :]].tolist():
            body, shape, kind = self._handles.pop(ptr)
            self.space.remove(body, shape)
            self._pool[kind].append((body, shape))
        self._relabel()

    def _feed_count(self) -> int:
        """Particles landing in this frame: Poisson with a log-normal AR(1) intensity."""
        p = self.params
        a = math.exp(-self.dt / p.feed_correlation_time)
        self._feed_log_intensity = a * self._feed_log_intensity + math.sqrt(1 - a * a) * self.rng.normal()
        sigma = p.feed_burstiness
        intensity = p.feed_rate * self.dt * math.exp(sigma * self._feed_log_intensity - 0.5 * sigma * sigma)
        return int(self.rng.poisson(intensity))

    def _drop(self, count: int) -> None:
        """Land ``count`` particles upstream of the window on parked bodies of their kinds (bodies
        are added to the space first if too few of a kind are parked)."""
        p, rng = self.params, self.rng
        kind_idx = (
            rng.choice(len(self.kinds), size=count, p=self.kind_weights)
            if len(self.kinds) > 1
            else np.zeros(count, dtype=np.int64)
        )
        uniform = rng.random((count, 2))
        normal = rng.normal(size=(count, 3))
        geometry = np.array([p.drop_x, p.drop_spread, p.window_width, self.travel, p.belt_speed])
        args = (kind_idx, uniform, normal, self._landing, self._half_size, geometry, self._next_id)
        while not land(self._rows, self._row_truth, self._row_kind, *args):
            parked = (self._row_truth == PARKED)[:, None] & (
                self._row_kind[:, None] == np.arange(len(self.kinds))
            )
            short = np.bincount(kind_idx, minlength=len(self.kinds)) - parked.sum(axis=0)
            for k in np.flatnonzero(short > 0).tolist():
                self._add_bodies(k, int(short[k]) + self.max_parked // (2 * len(self.kinds)))
        self._next_id += count
        self._n_parked -= count

    # -- dynamics -----------------------------------------------------------------------------
    def step(self) -> None:
        """Advance one camera frame: parking past the end, feed, belt friction, collisions."""
        p = self.params
        exits = park_exits(self._rows, self._row_truth, self.belt_end - self.travel)
        self._n_parked += exits
        poses = exits > 0
        count = self._feed_count()
        if count:
            self._drop(count)
            poses = True
        self._trim_parking()
        h = self.dt / p.substeps
        crossings = _NO_CROSSINGS
        for i in range(p.substeps):
            belt_friction(self._rows, self._row_truth, self._row_kind, self._decel, self._spin_decel, h)
            self._write(poses=poses and i == 0)
            before, travel_before = self._rows, self.travel
            self.space.step(h)
            self.travel += p.belt_speed * h
            self._read()
            if self.line_x is not None:
                ids, fraction, lateral = line_crossings(
                    before,
                    self._rows,
                    self._row_truth,
                    self.line_x - travel_before,
                    self.line_x - self.travel,
                )
                if len(ids):
                    found = (ids, (i + fraction) / p.substeps, lateral)
                    crossings = (
                        found
                        if crossings is _NO_CROSSINGS
                        else (
                            np.concatenate([crossings[0], found[0]]),
                            np.concatenate([crossings[1], found[1]]),
                            np.concatenate([crossings[2], found[2]]),
                        )
                    )
        self.crossings = crossings
        self.time += self.dt

    def warm_up(self) -> None:
        """Run the belt for ``warmup_time`` so that the first frame sees steady state."""
        for _ in range(round(self.params.warmup_time / self.dt)):
            self.step()

    def state(self, x_range: tuple[float, float] | None = None) -> BeltState:
        """Every particle on the belt (or with ``x_low <= x <= x_high``), ordered by truth id,
        in the ground frame."""
        low, high = (-np.inf, np.inf) if x_range is None else x_range
        ids, position, velocity, angle, kind = window_state(
            self._rows, self._row_truth, self._row_kind, low, high, self.travel, self.params.belt_speed
        )
        return BeltState(ids=ids, position=position, velocity=velocity, angle=angle, kind=kind)
