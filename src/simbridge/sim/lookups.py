"""The `Sim`'s lookups: body, joint and link ids and names, the joint-index arrays the
commands take (cached per body and argument), the joint and dynamics tables and the state
reads (a part of :class:`simbridge.Sim`)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from simbridge.exceptions import (
    InvalidArgumentError,
    SimClosedError,
    UnknownBodyError,
    UnknownJointError,
    UnknownLinkError,
)
from simbridge.sim.arguments import JointsArg, LinkArg, checked_state, command_values
from simbridge.types import BaseState, DynamicsInfo, JointInfo, JointStates, JointType, LinkState

if TYPE_CHECKING:
    from simbridge.backend import Backend

__all__ = ["Lookups"]


@dataclass
class _Body:
    name: str
    joint_names: list[str]
    link_names: list[str]
    joint_types: list[JointType]
    joint_index: dict[str, int]
    link_index: dict[str, int]
    cache: dict[Any, np.ndarray] = field(default_factory=dict)  # joints arg -> indices
    movable_cache: dict[Any, np.ndarray] = field(default_factory=dict)
    load: dict[str, Any] = field(default_factory=dict)  # how it was loaded (the manifest's)

    @property
    def has_spherical(self) -> bool:
        return JointType.SPHERICAL in self.joint_types


class _Closed:
    """Stands in for the backend after close(): any use raises SimClosedError."""

    def __getattr__(self, name: str) -> Any:
        raise SimClosedError()


class Lookups:
    """Ids, names, joint-index arrays, tables and state reads (a part of :class:`Sim`)."""

    if TYPE_CHECKING:  # provided by simbridge.sim.Sim
        _b: Backend
        _bodies: dict[int, _Body]
        _multi_idx: dict[int, np.ndarray]

    # the argument checks every command uses (simbridge.sim.arguments), reached as methods
    _values = staticmethod(command_values)
    _checked_state = staticmethod(checked_state)

    def _body(self, body: int, argument: str = "body") -> _Body:
        if type(body) is int:  # the hot path
            found = self._bodies.get(body)
            if found is not None:
                return found
        elif isinstance(body, np.integer):
            found = self._bodies.get(int(body))
            if found is not None:
                return found
        else:  # True would be body 1, 1.0 too: an id is an int
            self._b.time  # noqa: B018 - raises SimClosedError after close()
            raise InvalidArgumentError(
                argument, f"a body id is an int (as load_urdf returns it), got {body!r}"
            )
        self._b.time  # noqa: B018 - raises SimClosedError after close()
        raise UnknownBodyError(body, self._bodies)

    def joint_index(self, body: int, joint: int | str) -> int:
        """The index of a joint given by index or name."""
        b = self._body(body)
        if isinstance(joint, str):
            try:
                return b.joint_index[joint]
            except KeyError:
                raise UnknownJointError(
                    b.name, joint, b.joint_names, body=int(body), source=b.load.get("source")
                ) from None
        if isinstance(joint, (int, np.integer)) and not isinstance(joint, bool):
            if 0 <= joint < len(b.joint_names):
                return int(joint)
        raise UnknownJointError(
            b.name, joint, b.joint_names, body=int(body), source=b.load.get("source")
        )

    def link_index(self, body: int, link: LinkArg) -> int:
        """The index of a link given by index or name (-1 or the root's name = base)."""
        b = self._body(body)
        if isinstance(link, str):
            try:
                return b.link_index[link]
            except KeyError:
                raise UnknownLinkError(
                    b.name, link, b.link_names, body=int(body), source=b.load.get("source")
                ) from None
        if isinstance(link, (int, np.integer)) and not isinstance(link, bool):
            if -1 <= link < len(b.link_names):
                return int(link)
        raise UnknownLinkError(
            b.name, link, b.link_names, body=int(body), source=b.load.get("source")
        )

    def _joints(self, body: int, joints: JointsArg | None, movable: bool) -> np.ndarray:
        """Resolve a joints argument to an index array (cached per body and argument)."""
        b = self._body(body)
        if type(joints) is np.ndarray:  # the hot path first
            key: Any = (joints.dtype.char, joints.tobytes())
        elif joints is None:
            key = None
        elif isinstance(joints, (int, str, np.integer)):
            key = joints
        elif isinstance(joints, np.ndarray):
            key = (joints.dtype.char, joints.tobytes())
        else:
            if isinstance(joints, (set, frozenset, dict)):  # no order: which target is whose?
                raise InvalidArgumentError(
                    "joints",
                    f"expected an index, a name or an ordered sequence of them (list, tuple, "
                    f"array), got a {type(joints).__name__}: {joints!r}",
                )
            try:
                key = tuple(joints)
                hash(key)
            except TypeError:
                raise InvalidArgumentError(
                    "joints", f"expected an index, a name or a sequence of them, got {joints!r}"
                ) from None
        cache = b.movable_cache if movable else b.cache
        try:
            return cache[key]
        except KeyError:
            pass
        if joints is None:
            idx = [i for i, t in enumerate(b.joint_types) if t != JointType.FIXED or not movable]
        elif isinstance(joints, (int, str, np.integer)):
            idx = [self.joint_index(body, joints)]
        else:
            items = joints.tolist() if isinstance(joints, np.ndarray) else list(joints)
            idx = [self.joint_index(body, j) for j in items]
            if len(set(idx)) != len(idx):
                raise InvalidArgumentError("joints", f"a joint is given twice in {joints!r}")
        if movable:
            for i in idx:
                if b.joint_types[i] == JointType.FIXED:
                    raise InvalidArgumentError(
                        "joints",
                        f"joint {b.joint_names[i]!r} (index {i}) of body {b.name!r} is fixed "
                        "and takes no command",
                    )
        arr = np.asarray(idx, dtype=np.intp)
        arr.setflags(write=False)
        if movable and any(b.joint_types[i] == JointType.SPHERICAL for i in idx):
            self._multi_idx[id(arr)] = arr
        cache[key] = arr
        return arr

    # ---------------------------------------------------------------- tables

    def num_joints(self, body: int) -> int:
        """Number of joints (fixed ones included) = number of non-base links."""
        return len(self._body(body).joint_names)

    def joint_info(self, body: int, joint: int | str) -> JointInfo:
        """One row of the joint table (``p.getJointInfo``), by index or name."""
        return self._b.joint_info(body, self.joint_index(body, joint))

    def joints(self, body: int) -> list[JointInfo]:
        """The whole joint table, in index order."""
        return [self._b.joint_info(body, i) for i in range(self.num_joints(body))]

    def dynamics_info(self, body: int, link: LinkArg = -1) -> DynamicsInfo:
        """Mass, friction and inertia of a link as simulated (``p.getDynamicsInfo``)."""
        return self._b.dynamics_info(body, self.link_index(body, link))

    # ---------------------------------------------------------------- state

    def link_state(self, body: int, link: LinkArg) -> LinkState:
        """Pose and velocity of a link after the last step (base -1 allowed)."""
        return self._b.link_state(body, self.link_index(body, link))

    def base_state(self, body: int) -> BaseState:
        """The base's centre-of-mass pose and velocity (``getBasePositionAndOrientation``,
        ``getBaseVelocity``)."""
        self._body(body)
        return self._b.base_state(body)

    def joint_states(self, body: int, joints: JointsArg | None = None) -> JointStates:
        """Positions, velocities and motor forces of ``joints`` (default all), each (n,).

        A spherical joint reports its first coordinate, as ``p.getJointState`` does (its
        quaternion's x, its angular velocity's x, its motor torque about x); all of them:
        :meth:`joint_states_multi_dof`."""
        return self._b.joint_states(body, self._joints(body, joints, False))
