"""What the parts of one `Sim` share: :class:`Shared`, one per Sim.

The Sim's parts (:mod:`~simbridge.sim.lookups`, :mod:`~simbridge.sim.control`,
:mod:`~simbridge.sim.multi_dof`, :mod:`~simbridge.sim.world`, :mod:`~simbridge.sim.pictures`,
:mod:`~simbridge.sim.loading`, :mod:`~simbridge.sim.native`) are plain functions taking this
object; none of them holds state of its own. It keeps the backend, each body's tables, and the
bound commands in force with the joints they hold; the bookkeeping of those commands (bind,
refuse, release, end) is its own methods, so that the lists and the map of held joints change
together. It also keeps how its engine was made (:class:`EngineRecipe`: a model read with
``semantics="mujoco"`` replaces the engine, and ``reset()`` makes a new one) and that model
(:mod:`~simbridge.sim.native`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from simbridge.backend import Backend
from simbridge.bound import BoundCommand
from simbridge.exceptions import InvalidArgumentError, SimClosedError
from simbridge.profiles import Profile
from simbridge.types import JointType, Vec3

if TYPE_CHECKING:
    from simbridge.model.mjcf_native import NativeMjcf

__all__ = ["BodyTable", "EngineRecipe", "Shared"]


@dataclass
class BodyTable:
    """One loaded body's names and indices, as the backend's joint table gives them.

    Attributes:
        name: the body's ``<robot name>``.
        joint_names: joint i's name, by index.
        link_names: link i's name (joint i's child), by index; the base is not listed.
        joint_types: joint i's type, by index.
        joint_index: joint name -> index.
        link_index: link name -> index, the base's name -> -1.
        cache: a joints argument (its key) -> its index array, for reads.
        movable_cache: the same for commands (movable joints only).
        link_cache: a links argument (its key) -> its link-index array (``Sim.link_states``).
        load: how the body was loaded (its entry in ``Sim.manifest()["bodies"]``).
    """

    name: str
    joint_names: list[str]
    link_names: list[str]
    joint_types: list[JointType]
    joint_index: dict[str, int]
    link_index: dict[str, int]
    cache: dict[Any, np.ndarray] = field(default_factory=dict)  # joints arg -> indices
    movable_cache: dict[Any, np.ndarray] = field(default_factory=dict)
    link_cache: dict[Any, np.ndarray] = field(default_factory=dict)  # links arg -> indices
    load: dict[str, Any] = field(default_factory=dict)  # how it was loaded (the manifest's)

    @property
    def has_spherical(self) -> bool:
        """True if one of the body's joints is spherical."""
        return JointType.SPHERICAL in self.joint_types


@dataclass(frozen=True)
class EngineRecipe:
    """How a Sim's engine is made, and the gravity and time step its caller gave.

    Attributes:
        cls: the backend class.
        profile: the profile, with the Sim's gravity and time step.
        gui: open the engine's viewer.
        every_step: ``Sim(divergence_check="every_step")``.
        gravity: the gravity the caller gave (m/s², world); None: not given (an MJCF read with
            ``semantics="mujoco"`` then takes its ``<option>``'s).
        timestep: the time step the caller gave (s); None: not given, likewise.
    """

    cls: type[Backend]
    profile: Profile
    gui: bool
    every_step: bool
    gravity: Vec3 | None
    timestep: float | None

    def make(self) -> Backend:
        """A new engine: an empty world of this profile, its divergence check set.

        Returns:
            The backend.

        Raises:
            Whatever the backend's constructor or ``set_divergence_check`` raises (an engine
            made is closed first).
        """
        engine = self.cls(self.profile, self.gui)
        try:
            engine.set_divergence_check(self.every_step)
        except BaseException:
            engine.close()
            raise
        return engine


class _Closed:
    """Stands in for the backend after close(): any use raises SimClosedError."""

    def __getattr__(self, name: str) -> Any:
        raise SimClosedError()


class Shared:
    """The state one Sim's parts share (one per Sim, made empty and closed by the Sim).

    Attributes:
        backend: the engine (a :class:`~simbridge.backend.Backend`); after ``close()`` a
            stand-in whose every use raises :class:`~simbridge.exceptions.SimClosedError`.
        name: the registered backend name (``"pybullet"``, ``"mujoco"``...).
        dt: the fixed time step (s).
        bodies: body id -> its :class:`BodyTable`, in load order.
        commands: the bound commands, in binding order.
        presend: those of them the Sim sends before each step (the backend steps the others).
        held: body id -> joint index -> the bound command driving it.
        multi_idx: id -> a joint index array (from :func:`~simbridge.sim.lookups.joint_indices`)
            holding a spherical joint: the commands take such arrays to their multi-DoF path.
            The arrays are kept alive here, so that an id is never reused.
        recipe: how the engine was made (:class:`EngineRecipe`); None before it is.
        native: the model read with ``semantics="mujoco"`` the world holds (the backend is
            then the one ``Backend.mjcf_world`` made), else None.
    """

    __slots__ = (
        "backend",
        "name",
        "dt",
        "bodies",
        "commands",
        "presend",
        "held",
        "multi_idx",
        "recipe",
        "native",
    )

    def __init__(self) -> None:
        """A closed world with no bodies; the Sim sets the backend, name, time step and
        recipe."""
        self.backend: Backend = _Closed()  # type: ignore[assignment]
        self.name = ""
        self.dt = float("nan")
        self.recipe: EngineRecipe | None = None
        self.native: NativeMjcf | None = None
        self.bodies: dict[int, BodyTable] = {}
        self.commands: list[BoundCommand] = []
        self.presend: list[BoundCommand] = []
        self.held: dict[int, dict[int, BoundCommand]] = {}
        self.multi_idx: dict[int, np.ndarray] = {}

    @property
    def closed(self) -> bool:
        """True once the backend is released (or before it is made)."""
        return isinstance(self.backend, _Closed)

    def close(self) -> None:
        """Drop the backend (already released or failed), the bodies and the bound commands."""
        self.backend = _Closed()  # type: ignore[assignment]
        self.native = None
        self.bodies.clear()
        self.end_commands("the Sim was closed")

    # ---------------------------------------------------------------- bound commands

    def bind(self, command: BoundCommand) -> BoundCommand:
        """Send ``command`` once, mark its joints held and hand it to the backend.

        Args:
            command: a checked command on joints no other bound command holds.

        Returns:
            ``command``, now bound: sent before each step, by the Sim or by the backend.

        Raises:
            InvalidArgumentError: a value the first send refuses (nothing is bound then).
            Whatever the backend's ``bind_command`` raises (the command is released first).
        """
        command.send()  # the first command, through the plain path
        held = self.held.setdefault(command.body, {})
        for j in command.joints.tolist():
            held[j] = command
        self.commands.append(command)
        try:
            stepped = self.backend.bind_command(command)
        except BaseException:
            self.release(command)
            raise
        if not stepped:
            self.presend.append(command)
        return command

    def refuse_held(self, body: int, idx: np.ndarray) -> None:
        """Refuse a plain motor command on joints a bound command holds.

        Args:
            body: a loaded body's id.
            idx: ``(n,)`` joint indices.

        Raises:
            InvalidArgumentError: one of ``idx`` is held (the message names the joint).
        """
        held = self.held.get(body)
        if not held:
            return
        for j in idx.tolist():
            command = held.get(j)
            if command is not None:
                b = self.bodies[body]
                raise InvalidArgumentError(
                    "joints",
                    f"joint {b.joint_names[j]!r} (index {j}) of body {b.name!r} is driven by a "
                    f"bound {command.mode} command: write its targets, or release() it first",
                )

    def release(self, command: BoundCommand) -> None:
        """Unbind one command (:meth:`BoundCommand.release`). The backend unbinds first: a
        refusal (SimBusyError while another thread steps) leaves the command bound, here and
        there.

        Args:
            command: a command bound by :meth:`bind` (one already released is ignored).

        Raises:
            SimBusyError: another thread is stepping the Sim.
        """
        if not isinstance(self.backend, _Closed):
            self.backend.unbind_command(command)
        if command in self.commands:
            self.commands.remove(command)
        if command in self.presend:
            self.presend.remove(command)
        held = self.held.get(command.body, {})
        for j in command.joints.tolist():
            if held.get(j) is command:
                del held[j]
        if not held:
            self.held.pop(command.body, None)

    def end_commands(self, why: str) -> None:
        """End every bound command (a world change): each is unbound, then made stale.

        Args:
            why: what changed, for the StaleCommandError of a later use ("reset changed the
                world").
        """
        if not self.commands:
            return
        for command in list(self.commands):
            self.release(command)
            command._end(why)
