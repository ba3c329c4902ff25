"""The model error without accumulation: one step from the same state (:func:`resync`).

Engine A runs the scenario as :func:`simbridge.compare.run` runs it. Every ``every``-th step,
once that step's commands are issued and before it is taken, A's state is read
(``sim.get_state()``: base poses and velocities, joint positions and velocities, the commands
in force and pending torques) and its portable part is set

* into a Sim of engine B with the same robots loaded in the same order: B steps once, and its
  state is compared with A's next recorded state: **A -> B**, the one-step model error;
* into a second Sim of engine A: it steps once and is compared alike: **A -> A**, the floor,
  what a portable restore alone costs in that engine (docs/state_and_contacts.md: 0 without
  contact on both engines; PyBullet loses its contact manifolds and their warm start, MuJoCo its
  solver warm start).

The same is done from B's run (B -> A beside B -> B). Nothing accumulates: every comparison
starts from the source engine's own state. An engine that keeps its state in float32 (PhysX,
``Backend.state_dtype``) holds a state set into it rounded to float32: its step starts from the
rounded state, and its one-step error holds that rounding, measured at each point
(:attr:`Direction.rounding`: the state set against itself in the target's type).

Errors are measured on the followed robot (the scenario's subject): one distance in the
scenario's headline quantity (:data:`~simbridge.compare.diff.QUANTITIES`) and each of
:data:`PARTS`.

Both target Sims step once per resync point and keep what their engine keeps between steps
(PyBullet's contact caches from the previous resync point): a cross-engine step and the floor
step are taken alike, so the floor is the honest yardstick of the cross error.

The result in words and as a figure: :mod:`simbridge.compare.report.resync`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

import simbridge
from simbridge.exceptions import InvalidArgumentError, SimbridgeError
from simbridge.registry import state_dtype
from simbridge.types import JointType

from ..scenario import Scenario, load_scenario
from .events import Event, find_events, phase_at
from .portable import length
from .quantities import FEATURE_SOURCES, QUANTITIES, distance, features, rotation_angle
from .recording import run
from .trajectory import Trajectory

__all__ = [
    "DEFAULT_POINTS",
    "BORN_FACTOR",
    "PARTS",
    "Direction",
    "Resync",
    "default_every",
    "resync",
]

DEFAULT_POINTS = 150
"""Resync points per run the default ``every`` aims at: ``every = ceil(steps / 150)``."""
BORN_FACTOR = 10.0
"""The model error is *born* at the first resync point where the cross error exceeds this
times that point's floor and the precision floor, and the significant error
(:attr:`Resync.significant`: the one-step error that, repeated at every step of the run, would
add up to the tolerance)."""
FLOOR_RELATIVE = 1e-12
"""The precision floor: this times the largest recorded magnitude of the headline quantity's
source (at least 1), as the verdict's."""
WORST = 5
"""Worst steps listed per direction."""
EVENT_WINDOW = 0.1
"""s: a source-engine event that began up to this long before a worst step (or is in force
then) is listed with it."""

PARTS: dict[str, tuple[str, str]] = {
    "base_position": ("base position", "m"),
    "base_orientation": ("base orientation", "rad"),
    "base_linear_velocity": ("base linear velocity", "m/s"),
    "base_angular_velocity": ("base angular velocity", "rad/s"),
    "joint_positions": ("joint position", "rad"),
    "joint_velocities": ("joint velocity", "rad/s"),
}
"""Per-quantity errors: norms of the difference for the base's position (URDF link frame, m),
linear velocity (centre of mass, m/s) and angular velocity (rad/s, world); the rotation angle
between the base orientations (rad); the largest absolute difference over movable joints
(rad or m, rad/s or m/s)."""

_OBSERVED = (
    "base_position",
    "base_orientation",
    "base_linear_velocity",
    "base_angular_velocity",
    "joint_positions",
    "joint_velocities",
    "link_positions",
)


def default_every(steps: int) -> int:
    """The default resync interval for a run of ``steps`` steps: about :data:`DEFAULT_POINTS`
    resync points (every step for runs up to 150 steps; 7 for r2d2's 980)."""
    return max(1, math.ceil(steps / DEFAULT_POINTS))


# ---------------------------------------------------------------- results


class Peak(NamedTuple):
    """The largest value of a series over the resync points, the time (s) and phase of its
    point; all None when every value is NaN (the target never stepped)."""

    value: float | None
    time: float | None
    phase: str | None


@dataclass(frozen=True)
class PhaseErrors:
    """One phase's resync points (:meth:`Direction.by_phase`); a figure is None when every
    value of it in the phase is NaN."""

    phase: str
    points: int  # resync points whose step lies in the phase
    median: float | None  # of the error, the headline quantity's unit
    max: float | None
    floor_median: float | None  # of the floor
    floor_max: float | None


@dataclass(frozen=True)
class WorstPoint:
    """One of the resync points with the largest error (:attr:`Direction.worst`)."""

    time: float  # s, the source run's instant whose state was taken
    row: int  # its row in the source run
    phase: str  # the phase of the step
    error: float  # the headline quantity's unit
    floor: float | None  # None: the floor Sim failed to step
    parts: dict[str, float]  # per PARTS key, the error of that part
    events: list[Event]  # the source engine's events around it, nearest first (at most 4)


@dataclass(frozen=True)
class Born:
    """The first resync point whose error stands out (:meth:`Resync.born`)."""

    time: float  # s
    phase: str
    source: str  # the engine whose state was set
    target: str  # into this one
    error: float  # the headline quantity's unit
    floor: float


@dataclass
class Direction:
    """One direction: the states of engine ``source`` set into ``target`` (and into a second
    Sim of ``source``, the floor), one step each.

    Arrays are over the P resync points: ``rows`` (P,) the source run's row whose state was
    taken (the step goes from ``rows`` to ``rows + 1``), ``time`` (P,) s at that row,
    ``error`` and ``floor`` (P,) in the headline quantity's unit (NaN where the target failed
    to step), ``parts`` and ``floor_parts``: per :data:`PARTS` key, (P,)."""

    source: str
    target: str
    rows: np.ndarray
    time: np.ndarray
    error: np.ndarray
    floor: np.ndarray
    parts: dict[str, np.ndarray]
    floor_parts: dict[str, np.ndarray]
    phases: list[tuple[str, int, int]]
    failed: int = 0
    """Resync points at which a target Sim refused the state or failed its step."""
    worst: list[WorstPoint] = field(default_factory=list)
    target_dtype: str = "float64"
    """The type ``target`` keeps its state in (:func:`simbridge.registry.state_dtype`)."""
    rounding: dict[str, np.ndarray] | None = None
    """Where ``target`` keeps a narrower type than float64 (PhysX: float32): per :data:`PARTS`
    key, (P,), what rounding the state set into it to that type changes, the subject's base
    (its centre of mass) and joints as the state carries them; None where nothing is rounded
    (or in a result made before it was measured)."""

    def phase(self, k: int) -> str:
        """The phase of resync point ``k``'s step (the one whose commands were in force)."""
        return phase_at(self.phases, int(self.rows[k]) + 1)

    def peak(self, values: np.ndarray) -> Peak:
        """The largest of ``values`` (NaN ignored), when and in which phase."""
        if not np.isfinite(values).any():
            return Peak(None, None, None)
        k = int(np.nanargmax(values))
        return Peak(float(values[k]), float(self.time[k]), self.phase(k))

    def by_phase(self) -> list[PhaseErrors]:
        """Per phase (in order, those with resync points): the error and the floor in it."""
        names = [self.phase(k) for k in range(len(self.rows))]
        out = []
        for name, _, _ in self.phases:
            idx = [k for k, n in enumerate(names) if n == name]
            if not idx:
                continue
            e, f = self.error[idx], self.floor[idx]
            ok_e, ok_f = np.isfinite(e).any(), np.isfinite(f).any()
            out.append(
                PhaseErrors(
                    phase=name,
                    points=len(idx),
                    median=float(np.nanmedian(e)) if ok_e else None,
                    max=float(np.nanmax(e)) if ok_e else None,
                    floor_median=float(np.nanmedian(f)) if ok_f else None,
                    floor_max=float(np.nanmax(f)) if ok_f else None,
                )
            )
        return out


@dataclass
class Resync:
    """Both directions of the one-step comparison (:func:`resync`)."""

    every: int
    quantity: str
    labels: tuple[str, str]
    directions: list[Direction]
    """``[A -> B, B -> A]``."""
    precision_floor: float
    significant: float
    """The tolerance (the headline quantity's first threshold unless given) over the run's
    steps: a one-step error this large at every step would add up to the tolerance."""
    trajectories: list[Trajectory] = field(default_factory=list, repr=False)
    """Each engine's run the states were taken from (identical to its nominal run)."""
    wall_time: float = 0.0

    @property
    def unit(self) -> str:
        return QUANTITIES[self.quantity].unit

    def born(self) -> Born | None:
        """The first resync point (either direction) whose error exceeds :data:`BORN_FACTOR`
        times its floor and the precision floor, and :attr:`significant`; None when no point
        does."""
        first: Born | None = None
        for d in self.directions:
            level = BORN_FACTOR * np.maximum(np.nan_to_num(d.floor), self.precision_floor)
            level = np.maximum(level, self.significant)
            hit = np.flatnonzero(np.nan_to_num(d.error) > level)
            if hit.size == 0:
                continue
            k = int(hit[0])
            if first is None or d.time[k] < first.time:
                first = Born(
                    time=float(d.time[k]),
                    phase=d.phase(k),
                    source=d.source,
                    target=d.target,
                    error=float(d.error[k]),
                    floor=float(d.floor[k]),
                )
        return first


# ---------------------------------------------------------------- the driver


class _World:
    """A Sim with the scenario's robots loaded in its order (the world a state is set into)."""

    def __init__(self, sc: Scenario, backend: str, profile: str):
        self.args = (sc, backend, profile)
        self.sim = simbridge.Sim(
            backend,
            gravity=sc.gravity,
            timestep=sc.timestep,
            profile=sc.sim_profile(backend, profile),  # with the scenario's engine settings
        )
        try:
            self.ids: dict[str, int] = {}
            for r in sc.robots:
                self.ids[r.name] = sc.load_robot(self.sim, r)
            self.body = self.ids[sc.subject]
            self.joints, self.links = _layout(self.sim, self.body)
        except BaseException:
            self.sim.close()
            raise

    def step_from(self, state: simbridge.WorldState) -> dict[str, np.ndarray]:
        """Set ``state``, step once, observe the subject."""
        self.sim.set_state(state)
        self.sim.step()
        return _observe(self.sim, self.body, self.joints, self.links)

    def rebuilt(self) -> _World:
        self.sim.close()
        return _World(*self.args)


def _layout(sim: simbridge.Sim, body: int) -> tuple[np.ndarray, list[int]]:
    """The movable joints (index order) and the links (base -1 first) that run() records."""
    table = sim.joints(body)
    movable = np.array([j.index for j in table if j.type != JointType.FIXED], dtype=np.intp)
    return movable, list(range(-1, len(table)))


def _observe(
    sim: simbridge.Sim, body: int, joints: np.ndarray, links: list[int]
) -> dict[str, np.ndarray]:
    """The subject's state as :func:`~simbridge.compare.run.run` records a row (the same
    calls, ``Sim.link_states`` and ``Sim.joint_states``): base link frame pose, base
    velocities, joints, link centres of mass."""
    ls = sim.link_states(body, links)
    out = {
        "base_position": ls.link_frame_position[0].copy(),
        "base_orientation": ls.link_frame_orientation[0].copy(),
        "base_linear_velocity": ls.linear_velocity[0].copy(),
        "base_angular_velocity": ls.angular_velocity[0].copy(),
        "link_positions": ls.com_position.copy(),
    }
    if len(joints):
        js = sim.joint_states(body, joints)
        out["joint_positions"] = np.asarray(js.positions, dtype=np.float64)
        out["joint_velocities"] = np.asarray(js.velocities, dtype=np.float64)
    else:
        out["joint_positions"] = out["joint_velocities"] = np.zeros(0)
    return out


def _truth(tr: Trajectory, row: int) -> dict[str, np.ndarray]:
    b = tr.body
    return {k: np.asarray(getattr(b, k)[row], dtype=np.float64) for k in _OBSERVED}


def _errors(
    quantity: str, got: dict[str, np.ndarray], truth: dict[str, np.ndarray]
) -> tuple[float, dict[str, float]]:
    src = FEATURE_SOURCES[quantity]
    head = float(distance(quantity, features(quantity, got[src]), features(quantity, truth[src])))

    def largest(k: str) -> float:
        d = np.abs(got[k] - truth[k])
        return float(d.max(initial=0.0))

    parts = {
        "base_position": length(got["base_position"] - truth["base_position"]),
        "base_orientation": float(
            rotation_angle(got["base_orientation"], truth["base_orientation"])
        ),
        "base_linear_velocity": length(got["base_linear_velocity"] - truth["base_linear_velocity"]),
        "base_angular_velocity": length(
            got["base_angular_velocity"] - truth["base_angular_velocity"]
        ),
        "joint_positions": largest("joint_positions"),
        "joint_velocities": largest("joint_velocities"),
    }
    return head, parts


def _direction(
    sc: Scenario,
    source: tuple[str, str, str],
    target: tuple[str, str, str],
    every: int,
    quantity: str,
    progress: Callable[[int, int], None] | None,
) -> tuple[Direction, Trajectory]:
    """Run ``source`` (backend, profile, label), setting its every ``every``-th state into a
    Sim of ``target`` and into a second Sim of ``source``; one step each."""
    worlds = [_World(sc, target[0], target[1])]
    try:
        worlds.append(_World(sc, source[0], source[1]))
    except BaseException:
        worlds[0].sim.close()
        raise
    rows: list[int] = []
    got: list[list[dict[str, np.ndarray] | None]] = [[], []]
    failed = [0]
    dtype = state_dtype(target[0])
    narrow = np.dtype(dtype) != np.float64
    rounded: list[dict[str, float]] = []
    subject = worlds[1].body  # the source's subject: loaded in the same order as in its run

    def hook(sim: simbridge.Sim, row: int) -> None:
        if row % every:
            return
        state = sim.get_state(exact=False)  # the portable state: nothing engine-specific
        rows.append(row)
        if narrow:
            rounded.append(_rounding(state, subject, dtype))
        bad = False
        for i in (0, 1):
            try:
                got[i].append(worlds[i].step_from(state))
            except SimbridgeError:  # refused or diverged: this point is lost, not the run
                got[i].append(None)
                worlds[i] = worlds[i].rebuilt()
                bad = True
        failed[0] += bad

    try:
        tr = run(sc, source[0], profile=source[1], before_step=hook, progress=progress)
    finally:
        for w in worlds:
            w.sim.close()
    n = len(rows)
    err = np.full((2, n), np.nan)
    parts = [{k: np.full(n, np.nan) for k in PARTS} for _ in (0, 1)]
    for k, row in enumerate(rows):
        truth = _truth(tr, row + 1)
        for i in (0, 1):
            obs = got[i][k]
            if obs is None:
                continue
            err[i, k], p = _errors(quantity, obs, truth)
            for key, v in p.items():
                parts[i][key][k] = v
    r = np.array(rows, dtype=np.intp)
    d = Direction(
        source=source[2],
        target=target[2],
        rows=r,
        time=tr.time[r] if n else np.zeros(0),
        error=err[0],
        floor=err[1],
        parts=parts[0],
        floor_parts=parts[1],
        phases=list(tr.phases),
        failed=failed[0],
        target_dtype=dtype,
        rounding=(
            {k: np.array([x[k] for x in rounded], dtype=np.float64) for k in PARTS}
            if narrow
            else None
        ),
    )
    return d, tr


def _rounding(state: simbridge.WorldState, subject: int, dtype: str) -> dict[str, float]:
    """Per :data:`PARTS` key, what rounding ``subject``'s part of ``state`` to ``dtype``
    changes: as :func:`_errors` measures a part (the base position is the centre of mass's,
    as the state carries it)."""
    body = next(b for b in state.bodies if b.body == subject)
    kind = np.dtype(dtype).type

    def pair(v: Any) -> tuple[np.ndarray, np.ndarray]:
        a = np.asarray(v, dtype=np.float64)
        return a, a.astype(kind).astype(np.float64)

    def norm(v: Any) -> float:
        a, b = pair(v)
        return length(a - b)

    def largest(v: Any) -> float:
        a, b = pair(v)
        return float(np.abs(a - b).max(initial=0.0))

    q, q32 = pair(body.base_orientation)
    return {
        "base_position": norm(body.base_position),
        "base_orientation": float(rotation_angle(q, q32)),
        "base_linear_velocity": norm(body.base_linear_velocity),
        "base_angular_velocity": norm(body.base_angular_velocity),
        "joint_positions": largest(body.joint_positions),
        "joint_velocities": largest(body.joint_velocities),
    }


def _worst(d: Direction, tr: Trajectory, n: int = WORST) -> list[WorstPoint]:
    """The ``n`` resync points of ``d`` with the largest error, largest first, each with the
    source engine's events around it (:func:`~simbridge.compare.events.find_events`)."""
    if not np.isfinite(d.error).any():
        return []
    order = np.argsort(-np.nan_to_num(d.error, nan=-np.inf), kind="stable")[:n]
    try:
        evs = find_events(tr, label=d.source).events
    except Exception:  # noqa: BLE001 - the events are a courtesy; the figures stand alone
        evs = []
    dt = float(tr.timestep)
    out = []
    for k in order:
        if not np.isfinite(d.error[k]):
            continue
        t = float(d.time[k])
        near = []
        for e in evs:
            began = t - EVENT_WINDOW <= e.time <= t + dt
            ongoing = e.time <= t and (e.end is None or e.end >= t) and e.end != e.time
            if began or (ongoing and e.kind in ("airborne", "tipped_over", "contact_chatter")):
                near.append(e)
        near.sort(key=lambda e: abs(e.time - t))
        out.append(
            WorstPoint(
                time=t,
                row=int(d.rows[k]),
                phase=d.phase(int(k)),
                error=float(d.error[k]),
                floor=None if not np.isfinite(d.floor[k]) else float(d.floor[k]),
                parts={key: float(v[k]) for key, v in d.parts.items()},
                events=near[:4],
            )
        )
    return out


def resync(
    scenario: str | Path | Scenario,
    backends: Sequence[str] = ("pybullet", "mujoco"),
    *,
    profiles: Sequence[str] | None = None,
    labels: Sequence[str] | None = None,
    every: int | None = None,
    quantity: str | None = None,
    tolerance: float | None = None,
    progress: Callable[[str, int, int], None] | None = None,
) -> Resync:
    """The one-step error between two engines from each other's recorded states, and each
    engine's floor (module docstring).

    Args:
        scenario: a shipped name, a TOML path or a :class:`Scenario` (its time step and
            duration as they are: pass a scaled or truncated one for another).
        backends: the two backends A and B.
        profiles: one per backend (default the scenario's).
        labels: the engines' names in the results (default the backend names).
        every: take a state every this many steps (default :func:`default_every`); >= 1.
        quantity: the headline quantity (default the scenario's ``headline``, else
            ``base_distance``, ``link_distance`` for a fixed-base subject).
        tolerance: the gap below which the engines agree, in the quantity's unit (default its
            first threshold); over the run's steps it sets :attr:`Resync.significant`.
        progress: ``progress(what, done, total)`` in steps over both runs.

    Raises:
        InvalidArgumentError: a bad ``every``, ``quantity`` or backend pair.
        ScenarioError, SimbridgeError: as :func:`~simbridge.compare.run`.
    """
    import time as _time

    start = _time.perf_counter()
    sc = load_scenario(scenario)
    if len(backends) != 2:
        raise InvalidArgumentError("backends", f"expected two backend names, got {backends!r}")
    if every is None:
        every = default_every(sc.steps)
    if isinstance(every, bool) or not isinstance(every, int) or every < 1:
        raise InvalidArgumentError("every", f"expected a whole number of steps >= 1, got {every!r}")
    if quantity is None:
        fixed = sc.robot(sc.subject).fixed_base
        quantity = sc.headline or ("link_distance" if fixed else "base_distance")
    if quantity not in QUANTITIES:
        raise InvalidArgumentError(
            "quantity", f"expected one of {', '.join(QUANTITIES)}, got {quantity!r}"
        )
    profs = tuple(profiles) if profiles is not None else (sc.profile, sc.profile)
    names = tuple(labels) if labels is not None else tuple(backends)
    engines = [(backends[i], profs[i], names[i]) for i in (0, 1)]
    dirs, trs = [], []
    for i in (0, 1):
        what = f"one step from {names[i]}'s states"

        def tick(n: int, total: int, _i: int = i, _what: str = what) -> None:
            if progress is not None:
                progress(_what, _i * sc.steps + n, 2 * sc.steps)

        d, tr = _direction(sc, engines[i], engines[1 - i], every, quantity, tick)
        d.worst = _worst(d, tr)
        dirs.append(d)
        trs.append(tr)
    src = FEATURE_SOURCES[quantity]
    scale = max([1.0] + [float(np.max(np.abs(getattr(t.body, src)), initial=0.0)) for t in trs])
    return Resync(
        every=every,
        quantity=quantity,
        labels=(names[0], names[1]),
        directions=dirs,
        precision_floor=FLOOR_RELATIVE * scale,
        significant=(tolerance or QUANTITIES[quantity].thresholds[0]) / max(1, sc.steps),
        trajectories=trs,
        wall_time=_time.perf_counter() - start,
    )
