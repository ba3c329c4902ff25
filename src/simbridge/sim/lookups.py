"""The `Sim`'s lookups: a body's table, joint and link indices by index or name, and the
joint-index arrays the commands and reads take (cached per body and argument). Functions of
the Sim's :class:`~simbridge.sim.shared.Shared` state; every other part resolves its
arguments here."""

from __future__ import annotations

from typing import Any

import numpy as np

from simbridge.exceptions import (
    InvalidArgumentError,
    UnknownBodyError,
    UnknownJointError,
    UnknownLinkError,
)
from simbridge.sim.arguments import JointsArg, LinkArg, LinksArg
from simbridge.sim.shared import BodyTable, Shared
from simbridge.types import JointType

__all__ = ["body_table", "joint_index", "joint_indices", "link_index", "link_indices"]


def body_table(s: Shared, body: int, argument: str = "body") -> BodyTable:
    """The table of a loaded body.

    Args:
        s: the Sim's shared state.
        body: a body id (an int, as ``load_urdf`` returns it; a numpy integer is taken).
        argument: the argument's name in the error message.

    Returns:
        The body's :class:`~simbridge.sim.shared.BodyTable`.

    Raises:
        InvalidArgumentError: ``body`` is not an integer.
        UnknownBodyError: no such body (the message lists those loaded).
        SimClosedError: the Sim is closed.
    """
    if type(body) is int:  # the hot path
        found = s.bodies.get(body)
        if found is not None:
            return found
    elif isinstance(body, np.integer):
        found = s.bodies.get(int(body))
        if found is not None:
            return found
    else:  # True would be body 1, 1.0 too: an id is an int
        s.backend.time  # noqa: B018 - raises SimClosedError after close()
        raise InvalidArgumentError(
            argument, f"a body id is an int (as load_urdf returns it), got {body!r}"
        )
    s.backend.time  # noqa: B018 - raises SimClosedError after close()
    raise UnknownBodyError(body, s.bodies)


def joint_index(s: Shared, body: int, joint: int | str) -> int:
    """:meth:`simbridge.Sim.joint_index` on the Sim's shared state.

    Args:
        s: the Sim's shared state.
        body, joint: as the method's.

    Returns:
        The index (0 to n - 1).

    Raises:
        UnknownJointError: as the method's.
        UnknownBodyError, InvalidArgumentError, SimClosedError: as :func:`body_table`.
    """
    b = body_table(s, body)
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


def link_index(s: Shared, body: int, link: LinkArg) -> int:
    """:meth:`simbridge.Sim.link_index` on the Sim's shared state.

    Args:
        s: the Sim's shared state.
        body, link: as the method's (-1 or the root's name: the base).

    Returns:
        The index (-1 to n - 1).

    Raises:
        UnknownLinkError: as the method's.
        UnknownBodyError, InvalidArgumentError, SimClosedError: as :func:`body_table`.
    """
    b = body_table(s, body)
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
    raise UnknownLinkError(b.name, link, b.link_names, body=int(body), source=b.load.get("source"))


def _key(joints: JointsArg | LinksArg, argument: str = "joints") -> Any:
    """A joints (or links) argument's cache key (an ordered, hashable form of it)."""
    if isinstance(joints, (int, str, np.integer)):
        return joints
    if isinstance(joints, np.ndarray):
        return (joints.dtype.char, joints.tobytes())
    if isinstance(joints, (set, frozenset, dict)):  # no order: which target is whose?
        raise InvalidArgumentError(
            argument,
            f"expected an index, a name or an ordered sequence of them (list, tuple, "
            f"array), got a {type(joints).__name__}: {joints!r}",
        )
    try:
        key = tuple(joints)
        hash(key)
    except TypeError:
        raise InvalidArgumentError(
            argument, f"expected an index, a name or a sequence of them, got {joints!r}"
        ) from None
    return key


def joint_indices(s: Shared, body: int, joints: JointsArg | None, movable: bool) -> np.ndarray:
    """Resolve a joints argument to an index array (cached per body and argument).

    Args:
        s: the Sim's shared state.
        body: a body id.
        joints: an index, a name, an ordered sequence of them, an integer array, or None
            (every joint; every movable joint when ``movable``).
        movable: for a command: fixed joints are refused.

    Returns:
        ``(n,)`` ``np.intp``, read-only, in the order given; the same array object for the
        same argument (backends key their plans on it). One holding a spherical joint is
        listed in ``s.multi_idx``.

    Raises:
        InvalidArgumentError: an unordered or malformed argument, a joint given twice, a fixed
            joint for a command.
        UnknownJointError, UnknownBodyError, SimClosedError: as :func:`joint_index`.
    """
    b = body_table(s, body)
    if type(joints) is np.ndarray:  # the hot paths (an array, every joint): no call
        key: Any = (joints.dtype.char, joints.tobytes())
    elif joints is None:
        key = None
    else:
        key = _key(joints)
    cache = b.movable_cache if movable else b.cache
    try:
        return cache[key]
    except KeyError:
        pass
    if joints is None:
        idx = [i for i, t in enumerate(b.joint_types) if t != JointType.FIXED or not movable]
    elif isinstance(joints, (int, str, np.integer)):
        idx = [joint_index(s, body, joints)]
    else:
        items = joints.tolist() if isinstance(joints, np.ndarray) else list(joints)
        idx = [joint_index(s, body, j) for j in items]
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
        s.multi_idx[id(arr)] = arr
    cache[key] = arr
    return arr


def link_indices(s: Shared, body: int, links: LinksArg | None) -> np.ndarray:
    """Resolve a links argument to an index array (cached per body and argument).

    Args:
        s: the Sim's shared state.
        body: a body id.
        links: an index, a name, an ordered sequence of them, an integer array (-1 or the
            root's name: the base), or None (every link, the base first: -1, 0, ..., n - 1).

    Returns:
        ``(n,)`` ``np.intp``, read-only, in the order given; the same array object for the
        same argument.

    Raises:
        InvalidArgumentError: an unordered or malformed argument, a link given twice.
        UnknownLinkError, UnknownBodyError, SimClosedError: as :func:`link_index`.
    """
    b = body_table(s, body)
    if links is None:
        key: Any = None
    elif type(links) is np.ndarray:
        key = (links.dtype.char, links.tobytes())
    else:
        key = _key(links, "links")
    try:
        return b.link_cache[key]
    except KeyError:
        pass
    if links is None:
        idx = list(range(-1, len(b.link_names)))
    elif isinstance(links, (int, str, np.integer)):
        idx = [link_index(s, body, links)]
    else:
        items = links.tolist() if isinstance(links, np.ndarray) else list(links)
        idx = [link_index(s, body, k) for k in items]
        if len(set(idx)) != len(idx):
            raise InvalidArgumentError("links", f"a link is given twice in {links!r}")
    arr = np.asarray(idx, dtype=np.intp)
    arr.setflags(write=False)
    b.link_cache[key] = arr
    return arr
