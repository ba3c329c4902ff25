"""The MuJoCo backend's departures from PyBullet, as its manifest states them.

:data:`DEPARTURES` holds the ones every world has, each with its measured size;
:data:`HARD_LIMITS` the joint-limit one under the ``limit_rule = "hard"`` setting; and
:func:`body_departures` those of the bodies loaded (a link's mass raised, a spherical joint's
limit not enforced, shapes left out).
:meth:`MujocoBackend.manifest <simbridge.backends.mujoco.backend.MujocoBackend.manifest>` puts them
together.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING

from .model import MIN_INERTIA, MIN_MASS, RobotSpec

if TYPE_CHECKING:
    from .robots import Robot

__all__ = ["DEPARTURES", "HARD_LIMITS", "body_departures", "mass_bound_note"]

DEPARTURES = {
    "contact": (
        "soft contact (pair solref (2 dt, 1), 1 mm margin standing in for PyBullet's 1 mm "
        "collision margin) instead of PyBullet's sequential-impulse contact: r2d2 rests at "
        "z 0.47100 (PyBullet 0.47099); turning in place on 4 skidding wheels it hops up to "
        "4 mm (PyBullet 0.3 mm; raw MuJoCo also hops)"
    ),
    "cylinder": (
        "collision cylinders are true cylinders; PyBullet collides with a 32-gon prism "
        "(its radius varies by 0.5 %)"
    ),
    "restitution": "MuJoCo has no restitution: <contact restitution> is reported, not applied",
    "rolling/spinning friction": (
        "MuJoCo's rolling and torsional friction (condim 6/4) with Bullet's combination "
        "rule; the models differ (all 0 under both profiles unless <contact> says so)"
    ),
    "joint limits": (
        "PyBullet's limit rule (stop outward motion; within 0.04 of the limit push back at "
        "0.2 depth/dt, deeper only stop) on MuJoCo's limit rows, hardened but not polished: "
        "a slider reset past its limit ends within 4.7e-7 m of PyBullet's"
    ),
    "motors": (
        "motor rows solved exactly (MuJoCo row hardened, then its shortfall removed); "
        "PyBullet's 50 solver iterations leave coupled motor rows up to 7e-4 rad/s short "
        "(double pendulum, measured), and a spherical joint's three rows, coupled where the "
        "child's inertia about the joint is not diagonal in its frame, far shorter "
        "(robots/spherical_pendulum.urdf, one step from rest 0.7 rad from the target: "
        "2.07 of 6.68 rad/s asked; 0.03 at 200 iterations)"
    ),
    "speed clamp": (
        "applied to the velocity after the solve, at every step, as PyBullet does; "
        "on a free base to the centre of mass's velocity (as PyBullet) and to the angular "
        "velocity in the base's frame (PyBullet: the world frame)"
    ),
    "joint axis": (
        "MuJoCo normalises a non-unit <axis>; PyBullet moves |axis| rad per unit of q "
        "(none of pybullet_data's joints that load has one of length != 1 by more than 1e-6)"
    ),
}

HARD_LIMITS = (
    "limit_rule 'hard', PhysX's rule, not PyBullet's: a joint arriving at its limit is "
    "stopped on it within the step (PyBullet lets it pass by up to one step's travel, then "
    "pushes it back); past it, PyBullet's push-back (motor_rows.py). The slider at 1 m/s "
    "toward its 0.4 m limit: 0.4 m, PyBullet 0.40081 m, PhysX 0.4 m (bench/limit_rule.py)"
)


def body_departures(robots: Iterable[Robot]) -> dict[str, str]:
    """The departures of the bodies loaded, keyed ``"body <id> <what>"``.

    First the mass bound of every body that has one, then each body's spherical joint limits
    and shapes left out, in the order the bodies were loaded.

    Args:
        robots: The loaded robots, in load order.

    Returns:
        Each departure's key and text, in that order.
    """
    robots = list(robots)
    departures: dict[str, str] = {}
    bounded = [r for r in robots if r.spec.bounded_links]
    for r in bounded:
        departures[f"body {r.id} mass bound"] = mass_bound_note(r.spec)
    for r in robots:
        if r.spec.unlimited_spherical:
            departures[f"body {r.id} spherical joint limits"] = (
                f"{r.spec.unlimited_spherical}: PyBullet's btMultiBodySphericalJointLimit "
                "(swing about x within <limit lower>, about y within upper, twist within "
                "twist) is not enforced; the joint moves freely past it (PyBullet's default "
                "spherical motor holds the joint at the identity, inside the limit, until "
                "released)"
            )
        if r.spec.skipped_shapes:
            departures[f"body {r.id} shapes left out"] = (
                f"{r.spec.skipped_shapes}: meshes without a finite vertex or a readable "
                "triangle (PyBullet loads them without a shape too)"
            )
    return departures


def mass_bound_note(robot: RobotSpec) -> str:
    """The manifest's note on a robot's links whose zero mass or inertia was raised.

    Args:
        robot: The robot, with its ``bounded_links``.

    Returns:
        One sentence naming the links and the bounds.
    """
    return (
        f"links {robot.bounded_links} move but have zero mass or inertia: raised to "
        f"{MIN_MASS} kg / {MIN_INERTIA} kg m^2 (MuJoCo refuses zero)"
    )
