"""The scenario data: robots, phases, commands and the :class:`Scenario` that holds them,
with the time-step helpers. Read and written as TOML by :mod:`.scenario_reader` and
:mod:`.scenario_writer`; :mod:`.scenario` is the public face (see its docstring for the file
format)."""

from __future__ import annotations

import math
import numbers
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from fractions import Fraction
from pathlib import Path
from typing import Any

import simbridge
from simbridge.engine_settings import freeze, merge, thaw
from simbridge.exceptions import InvalidArgumentError
from simbridge.transforms import quat_multiply
from simbridge.types import JointType

from ..errors import ScenarioError
from .controllers import ControllerSpec
from .outcomes import Outcome

MAX_STEPS = 1_000_000  # per phase: the recording holds about 0.7 kB per step for r2d2
MODES = ("velocity", "position", "torque")
HEADLINE_QUANTITIES = (
    "base_distance",
    "link_distance",
    "heading",
    "orientation",
    "joint_position_rms",
    "joint_velocity_rms",
)
"""The quantities of :data:`simbridge.compare.QUANTITIES` a scenario may name as its headline."""

JointRef = int | str


@dataclass(frozen=True)
class Command:
    """A joint command held during a phase (re-issued before every step)."""

    robot: str
    joints: tuple[JointRef, ...]
    mode: str  # "velocity" | "position" | "torque"
    target: tuple[float, ...]
    """One value per joint: rad/s or m/s (velocity), rad or m (position), N·m or N (torque)."""
    max_force: tuple[float, ...] | None = None
    """One value per joint (N·m or N); None for torque commands."""
    kp: float | None = None
    kd: float | None = None


@dataclass(frozen=True)
class Phase:
    name: str
    steps: int
    commands: tuple[Command, ...] = ()
    controller: ControllerSpec | None = None
    """A closed-loop controller run during this phase (see
    :mod:`simbridge.compare.controllers`), or None."""


@dataclass(frozen=True)
class RobotSpec:
    name: str
    urdf: str
    position: tuple[float, float, float] = (0.0, 0.0, 0.0)
    orientation: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 1.0)  # x, y, z, w
    fixed_base: bool = False
    joint_positions: tuple[tuple[JointRef, float], ...] = ()
    kind: str = "urdf"
    """``"urdf"`` (``Sim.load_urdf``) or ``"mjcf"`` (``Sim.load_mjcf``: ``urdf`` is then the MJCF
    file, which places the body itself; ``position`` and ``orientation`` then move it from
    there: a displacement (m, world) and a turn (x, y, z, w, world frame, about its centre of
    mass), zero from a scenario file, an ensemble's offsets otherwise)."""
    body: int = 0
    """An MJCF robot: which of the bodies its file makes (PyBullet's order)."""
    semantics: str = "pybullet"
    """An MJCF robot: how its file is read (``Sim.load_mjcf(semantics=...)``): ``"pybullet"``,
    as ``p.loadMJCF`` reads it, or ``"mujoco"``, as MuJoCo compiles it (the file is then the
    whole world: its floor, its ``<option>``, its actuators)."""


@dataclass(frozen=True)
class Scenario:
    """A comparison scenario. Compare two with ``==`` (the source file is not compared)."""

    name: str
    robots: tuple[RobotSpec, ...]
    phases: tuple[Phase, ...]
    timestep: float = 1.0 / 240.0
    gravity: tuple[float, float, float] = (0.0, 0.0, -9.8)
    profile: str = "pybullet"
    description: str = ""
    subject: str = ""
    """Name of the robot the report follows (set to the last robot when the file leaves it out)."""
    headline: str = ""
    """The report's headline quantity; "" = ``base_distance`` for a free base, else
    ``link_distance``."""
    source: Path | None = field(default=None, compare=False)
    """The file this scenario was read from (URDF paths are relative to its folder)."""
    outcomes: tuple[Outcome, ...] = ()
    """What success means (:mod:`simbridge.compare.outcomes`), measured on every run."""
    cut_at: float | None = field(default=None, compare=False)
    """Seconds :meth:`truncated` cut the scenario to (None: it runs whole); the outcomes say
    when a phase they measure was not run, or cannot be measured, because of it."""
    engines: Any = ()
    """Engine settings per backend (``[engines.mujoco]``: :mod:`simbridge.engine_settings`),
    checked and frozen; a mapping ``{backend: {key: value}}`` given here is frozen too."""
    gains_timestep: float | None = None
    """The time step the position gains (``kp``, ``kd`` of PyBullet's law, whose velocity
    change has the step in it) were written for: the scenario's own, once
    :meth:`with_timestep` moves it (None: the step it runs at). At another step a run sends the
    gains that make the same controller (:mod:`simbridge.compare.run.gains`)."""

    def __post_init__(self) -> None:
        object.__setattr__(self, "engines", freeze(self.engines, "engines"))

    def engine(self, backend: str) -> dict[str, Any]:
        """The engine settings this scenario sets for ``backend`` (empty when none)."""
        return thaw(self.engines).get(backend, {})

    def engine_settings(self) -> dict[str, dict[str, Any]]:
        """Every engine setting this scenario sets, by backend (JSON-able)."""
        return thaw(self.engines)

    def with_engine_settings(self, settings: Any) -> Scenario:
        """The same scenario with ``settings`` (``{backend: {key: value}}``) on top of its own,
        key by key.

        Raises:
            UnknownBackendError, InvalidProfileError: an unknown backend, key or bad value.
        """
        if not settings:
            return self
        merged = merge(thaw(self.engines), thaw(freeze(settings, "engine_settings")))
        return replace(self, engines=merged)

    def sim_profile(self, backend: str, profile: str | simbridge.Profile) -> Any:
        """What to give ``Sim(profile=)`` on ``backend``: ``profile`` itself when this scenario
        sets no engine setting for it, else the profile with them."""
        settings = self.engine(backend)
        if not settings:
            return profile
        return simbridge.get_profile(profile).with_engine(backend, **settings)

    @property
    def closed_loop(self) -> bool:
        """Whether a phase runs a controller."""
        return any(p.controller is not None for p in self.phases)

    @property
    def folder(self) -> Path | None:
        """The folder file references (URDFs, controllers, functions) are relative to: the
        source file's, or None (the current folder) for a scenario made in Python."""
        return self.source.parent if self.source is not None else None

    def with_controller(
        self,
        controller: Any,
        params: dict[str, Any] | None = None,
        every: int | None = None,
        *,
        phases: Sequence[str] | None = None,
    ) -> Scenario:
        """The same scenario with ``controller`` driving every phase (or the phases named in
        ``phases``), in place of their own. ``controller``: a class or factory function
        defined at the top level of a module or script, a ``"file.py:Name"`` or
        ``"package.module:Name"`` reference, or a :class:`ControllerSpec`; ``params`` its
        keyword arguments; ``every`` its period in steps."""
        spec = ControllerSpec.of(controller, params, every)
        names = {p.name for p in self.phases}
        for name in phases or ():
            if name not in names:
                raise ScenarioError(
                    self._where(), "phases", f"no phase {name!r}; phases: {sorted(names)}"
                )
        chosen = set(phases) if phases is not None else names
        return replace(
            self,
            phases=tuple(
                replace(p, controller=spec) if p.name in chosen else p for p in self.phases
            ),
        )

    @property
    def steps(self) -> int:
        """Total number of steps."""
        return sum(p.steps for p in self.phases)

    @property
    def duration(self) -> float:
        """Simulated time (s)."""
        return self.steps * self.timestep

    def robot(self, name: str) -> RobotSpec:
        for r in self.robots:
            if r.name == name:
                return r
        raise KeyError(name)

    def with_timestep(self, timestep: float) -> Scenario:
        """The same scenario at another time step: each phase keeps its duration, so its step
        count is scaled (``1/480`` doubles every phase). Raises :class:`ScenarioError` when a
        phase does not last a whole number of the new steps."""
        if not (isinstance(timestep, (int, float)) and math.isfinite(timestep) and timestep > 0):
            raise ScenarioError(self._where(), "timestep", f"must be > 0, got {timestep!r}")
        ratio = self.timestep / timestep
        phases = []
        for i, p in enumerate(self.phases):
            steps = p.steps * ratio
            if abs(steps - round(steps)) > 1e-6 * max(1.0, steps):
                raise ScenarioError(
                    self._where(),
                    f"phases[{i}].steps",
                    f"phase {p.name!r} lasts {p.steps * self.timestep:.6g} s, which is not a whole "
                    f"number of {format_timestep(timestep)} s steps ({steps:.6g})",
                )
            if round(steps) > MAX_STEPS:
                raise ScenarioError(
                    self._where(),
                    f"phases[{i}].steps",
                    f"phase {p.name!r} at {format_timestep(timestep)} s would take "
                    f"{round(steps)} steps; at most {MAX_STEPS} per phase",
                )
            ctl = p.controller
            if ctl is not None:
                every = ctl.every * ratio
                if abs(every - round(every)) > 1e-6 * max(1.0, every) or round(every) < 1:
                    raise ScenarioError(
                        self._where(),
                        f"phases[{i}].controller.every",
                        f"the controller of phase {p.name!r} runs every "
                        f"{ctl.every * self.timestep:.6g} s, which is not a whole number of "
                        f"{format_timestep(timestep)} s steps ({every:.6g})",
                    )
                ctl = replace(ctl, every=int(round(every)))
            phases.append(replace(p, steps=int(round(steps)), controller=ctl))
        written = self.timestep if self.gains_timestep is None else self.gains_timestep
        return replace(self, timestep=float(timestep), phases=tuple(phases), gains_timestep=written)

    def truncated(self, duration: float) -> Scenario:
        """The first ``duration`` seconds of the scenario (phases cut or dropped), rounded to
        whole steps. Raises InvalidArgumentError for a duration that is not a finite number of
        seconds > 0, or so short that no step would run (a run of nothing "agreed")."""
        if isinstance(duration, bool) or not isinstance(duration, numbers.Real):
            raise InvalidArgumentError("duration", f"expected seconds, got {duration!r}")
        duration = float(duration)
        if not (duration > 0 and math.isfinite(duration)):
            raise InvalidArgumentError("duration", f"must be a finite number > 0, got {duration!r}")
        left = int(round(duration / self.timestep))
        if left < 1:
            raise InvalidArgumentError(
                "duration",
                f"{duration:g} s is less than half of scenario {self.name!r}'s time step "
                f"({self.timestep:g} s): no step would run",
            )
        cut_at = left * self.timestep if left < self.steps else self.cut_at
        phases = []
        for p in self.phases:
            if left <= 0:
                break
            phases.append(replace(p, steps=min(p.steps, left)))
            left -= p.steps
        return replace(self, phases=tuple(phases), cut_at=cut_at)

    def resolve_urdf(self, robot: RobotSpec) -> str:
        """The URDF argument for ``Sim.load_urdf``: a path next to the scenario file when one
        exists there, else the name as written (searched on simbridge's path)."""
        if self.source is not None:
            candidate = self.source.parent / robot.urdf
            if candidate.is_file():
                return str(candidate)
        return robot.urdf

    def load_robot(self, sim: simbridge.Sim, robot: RobotSpec) -> int:
        """Load ``robot`` into ``sim`` (``load_urdf`` at its pose, or ``load_mjcf``, whose other
        bodies are loaded with it) and return its body id."""
        source = self.resolve_urdf(robot)
        if robot.kind == "mjcf":
            ids = sim.load_mjcf(source, semantics=robot.semantics)
            if robot.body >= len(ids):
                raise ScenarioError(
                    self._where(),
                    f"robots.{robot.name}.body",
                    f"{robot.urdf!r} makes {len(ids)} bodies (0 to {len(ids) - 1}), "
                    f"not {robot.body}",
                )
            body = ids[robot.body]
            if robot.position != (0.0, 0.0, 0.0) or robot.orientation != (0.0, 0.0, 0.0, 1.0):
                if robot.semantics == "mujoco" and not _free(sim, body):
                    _nudge_joints(sim, body, robot)
                    return body
                base = sim.base_state(body)  # its centre-of-mass frame, where the file put it
                sim.reset_base_state(
                    body,
                    position=[p + d for p, d in zip(base.position, robot.position, strict=True)],
                    orientation=quat_multiply(robot.orientation, base.orientation),
                )
            return body
        return sim.load_urdf(
            source,
            base_position=robot.position,
            base_orientation=robot.orientation,
            fixed_base=robot.fixed_base,
        )

    def _where(self) -> str:
        return str(self.source) if self.source else f"<scenario {self.name}>"


# ---------------------------------------------------------------- time steps


def parse_timestep(value: Any) -> float:
    """A time step from a number or a string such as ``"1/240"`` or ``"0.002"``."""
    if isinstance(value, bool):
        raise ValueError(f"expected a number of seconds or a fraction like '1/240', got {value!r}")
    if isinstance(value, (int, float)):
        try:
            out = float(value)
        except OverflowError:
            out = math.inf
    elif isinstance(value, str):
        try:
            out = float(Fraction(value.strip()))
        except OverflowError:
            out = math.inf
        except (ValueError, ZeroDivisionError):
            raise ValueError(
                f"expected a number of seconds or a fraction like '1/240', got {value!r}"
            ) from None
    else:
        raise ValueError(f"expected a number of seconds or a fraction like '1/240', got {value!r}")
    if not math.isfinite(out) or out <= 0:
        raise ValueError(f"must be a finite number > 0, got {value!r}")
    return out


def format_timestep(dt: float) -> str:
    """``1/240`` for a time step that is the float of a simple fraction, else ``repr``."""
    frac = Fraction(dt).limit_denominator(1_000_000)
    if float(frac) == dt and frac.numerator == 1:
        return f"1/{frac.denominator}"
    return repr(dt)


def _free(sim: simbridge.Sim, body: int) -> bool:
    """Whether a body of a model read as MuJoCo reads it has a free joint: ``qpos`` holds 7
    coordinates more than its joint rows' (one body: the scenario's whole world)."""
    rows = [sim.joint_info(body, j) for j in range(sim.num_joints(body))]
    sizes = {JointType.REVOLUTE: 1, JointType.PRISMATIC: 1, JointType.SPHERICAL: 4}
    return len(sim.qpos()) > sum(sizes.get(r.type, 0) for r in rows)


def _nudge_joints(sim: simbridge.Sim, body: int, robot: RobotSpec) -> None:
    """An ensemble's offset of a model read as MuJoCo reads it whose base the file fixes (no
    free joint: its place is the file's): the offset moves its hinge and slide coordinates
    instead, coordinate ``i`` by component ``i mod 6`` of (displacement, rotation vector) (m
    or rad: the same 1e-9 scale), so its members start apart as a free base's do."""
    x, y, z, w = robot.orientation
    half = math.atan2(math.sqrt(x * x + y * y + z * z), w)
    scale = 2.0 * half / math.sin(half) if half > 1e-12 else 2.0
    offset = [*robot.position, x * scale, y * scale, z * scale]
    qpos = sim.qpos()
    scalar = [
        sim.joint_info(body, j).q_index
        for j in range(sim.num_joints(body))
        if sim.joint_info(body, j).type in (JointType.REVOLUTE, JointType.PRISMATIC)
    ]
    for i, adr in enumerate(scalar):
        qpos[adr] += offset[i % 6]
    sim.set_qpos_qvel(qpos=qpos)
