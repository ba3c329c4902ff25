"""``simbridge joints``: a URDF's joint table as a backend loads it, as text or JSON.

One row per joint in PyBullet's order (index, name, type, parent -> child link, position limits,
max force and velocity, axis, damping, friction; units per joint type), or with ``--json`` every
field of each joint's :class:`~simbridge.types.JointInfo`.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from typing import Any

__all__ = ["add_command"]


def add_command(
    sub: Any, backends: list[str], verbose: Callable[[argparse.ArgumentParser], None]
) -> None:
    """Add ``simbridge joints`` (its parser's ``handler`` set).

    Args:
        sub: The top-level parser's subparsers.
        backends: The installed backends' names (``--backend``'s choices).
        verbose: Adds ``--verbose`` to a parser.
    """
    j = sub.add_parser(
        "joints",
        help="print a URDF's joint table as a backend loads it",
        description="Print the joint table as a backend loads the URDF: one row per joint "
        "(index, name, type, parent -> child link, position limits, max force and velocity, "
        "axis in the child's inertial frame, damping, friction; units per joint type: rad, "
        "N·m, rad/s for revolute joints, m, N, m/s for prismatic ones). --json gives every "
        "joint's 17 fields in PyBullet's getJointInfo order.",
    )
    j.add_argument("urdf", metavar="URDF", help="a path or a name on the search path")
    j.add_argument("--backend", default="pybullet", choices=backends)
    j.add_argument("--fixed-base", action="store_true", help="load with a fixed base")
    j.add_argument("--movable", action="store_true", help="movable joints only (not fixed)")
    j.add_argument("--json", action="store_true", help="JSON on stdout, for machines")
    verbose(j)
    j.set_defaults(handler=_joints)


_UNITS = {  # per joint type: position, force, velocity, damping, friction
    "revolute": ("rad", "N·m", "rad/s", "N·m·s/rad", "N·m"),
    "prismatic": ("m", "N", "m/s", "N·s/m", "N"),
}


def _num(x: float, unit: str = "") -> str:
    return f"{x:.6g} {unit}".rstrip()


def _joint_rows(infos: list[Any], base: str) -> list[list[str]]:
    """One row of text per joint, the table's columns (units per joint type)."""
    rows = []
    for j in infos:
        kind = j.type.name.lower()
        parent = base if j.parent_index < 0 else infos[j.parent_index].link_name
        cells = [str(j.index), j.name, kind, f"{parent} -> {j.link_name}"]
        units = _UNITS.get(kind)
        if units is None:  # fixed: nothing moves
            cells += ["-"] * 7
        else:
            pos, force, vel, damp, fric = units
            limited = j.lower_limit <= j.upper_limit  # PyBullet's 0, -1: no limits
            cells += [
                _num(j.lower_limit, pos) if limited else "none",
                _num(j.upper_limit, pos) if limited else "none",
                _num(j.max_force, force),
                _num(j.max_velocity, vel),
                "(" + ", ".join(f"{a:.4g}" for a in j.axis) + ")",
                _num(j.damping, damp),
                _num(j.friction, fric),
            ]
        rows.append(cells)
    return rows


_HEADER = [
    "index",
    "name",
    "type",
    "parent -> child link",
    "lower",
    "upper",
    "max force",
    "max velocity",
    "axis",
    "damping",
    "friction",
]


def _joints(args: argparse.Namespace) -> int:
    import json

    import simbridge
    from simbridge.model.urdf import parse_urdf, resolve_source

    base = parse_urdf(resolve_source(args.urdf)).base.name  # the root link: parent -1
    with simbridge.Sim(args.backend) as sim:
        body = sim.load_urdf(args.urdf, fixed_base=args.fixed_base)
        infos = sim.joints(body)
        robot = sim.body_name(body)
    shown = [j for j in infos if j.type != simbridge.JointType.FIXED or not args.movable]
    if args.json:
        joints = []
        for j in shown:
            row = j._asdict()
            row["type"] = {"name": j.type.name.lower(), "number": int(j.type)}
            joints.append(row)
        doc = {
            "robot": robot,
            "backend": args.backend,
            "fixed_base": args.fixed_base,
            "base_link": base,
            "joints": joints,
        }
        print(json.dumps(doc, indent=2))
        return 0
    rows = [r for r, j in zip(_joint_rows(infos, base), infos, strict=True) if j in shown]
    widths = [max(len(r[k]) for r in [_HEADER, *rows]) for k in range(len(_HEADER))]
    right = {0, 4, 5, 6, 7, 9, 10}  # numbers: right-aligned
    for r in [_HEADER, *rows]:
        cells = [
            c.rjust(w) if k in right else c.ljust(w)
            for k, (c, w) in enumerate(zip(r, widths, strict=True))
        ]
        print("  ".join(cells).rstrip())
    movable = sum(j.type != simbridge.JointType.FIXED for j in infos)
    print(
        f"{robot}: {len(infos)} joints, {movable} movable, base link {base}"
        f"{' (fixed)' if args.fixed_base else ''}; backend {args.backend}"
    )
    return 0
