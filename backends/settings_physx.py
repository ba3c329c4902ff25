"""PhysX's engine settings (SAPIEN 3): the scene's and the shapes' knobs users tune.

Imports no engine (read when a profile or a scenario is checked). The defaults are what the
backend builds a world with today (backend.py, model.py): PGS, one velocity iteration, a 1 cm
contact offset, a 0.5 mm rest offset, bounce threshold 2 m/s, no depenetration speed cap,
PhysX's hard joint limits (physx/limits.py), and SAPIEN's own scene flags. Left out: position
iterations (the profile's ``solver_iterations``).
"""

from __future__ import annotations

from typing import Any

from simbridge.engine_settings import Setting

REST_OFFSET_DEFAULT = 0.0005  # m, per shape

SETTINGS = (
    Setting(
        "solver",
        "choice",
        "PGS",
        "constraint solver: 'PGS' (projected Gauss-Seidel, PyBullet's kind) or 'TGS' "
        "(temporal Gauss-Seidel, PhysX's default)",
        choices=("PGS", "TGS"),
        toward="mujoco.solver",
    ),
    Setting(
        "solver_velocity_iterations",
        "int",
        1,
        "velocity iterations of each articulation's solve (after its position iterations)",
        low=0,
        high=255,
    ),
    Setting(
        "contact_offset",
        "float",
        0.01,
        "distance at which a shape's contacts are made (per shape; a pair uses the sum)",
        unit="m",
        low=0.0,
        low_open=True,
        toward="mujoco.margin",
    ),
    Setting(
        "rest_offset",
        "float",
        REST_OFFSET_DEFAULT,
        "distance at which a shape comes to rest (per shape; a pair rests the sum apart); "
        "below contact_offset",
        unit="m",
        low=0.0,
        toward="pybullet.contactSlop",
    ),
    Setting(
        "bounce_threshold",
        "float",
        2.0,
        "approach speed under which a contact does not bounce",
        unit="m/s",
        low=0.0,
        toward="pybullet.restitutionVelocityThreshold",
    ),
    Setting(
        "max_depenetration_velocity",
        "float",
        1e32,
        "the most speed a penetrating link is given to leave the penetration",
        unit="m/s",
        low=0.0,
        low_open=True,
        toward="pybullet.splitImpulsePenetrationThreshold",
    ),
    Setting(
        "limit_rule",
        "choice",
        "hard",
        "how a joint's position limit acts: 'hard' (PhysX's: a joint arriving at its limit is "
        "stopped on it within the step; one found past it, after a write of the state, gets "
        "PyBullet's push-back) or 'pybullet' (PyBullet's: no limit until a step starts at or "
        "past it, so a joint passes by up to one step's travel, then is pushed back at 0.2 of "
        "the depth per step; backends/physx/limits.py)",
        choices=("hard", "pybullet"),
        toward="mujoco.limit_rule",
    ),
    Setting(
        "enable_pcm",
        "bool",
        True,
        "persistent contact manifolds (false: PhysX's legacy contact generation)",
    ),
    Setting(
        "enable_friction_every_iteration",
        "bool",
        True,
        "friction solved in every iteration (false: only in the last few)",
    ),
    Setting(
        "enable_enhanced_determinism",
        "bool",
        False,
        "results independent of the order bodies were added in, at some cost",
    ),
)


def check_together(
    values: dict[str, Any], given: frozenset[str] = frozenset()
) -> tuple[str, str] | None:
    """Checks that the rest offset is below the contact offset.

    PhysX makes a shape's contacts within its contact offset and rests it at its rest offset, so
    the rest offset must be below the contact offset.

    Args:
        values: The PhysX settings in force, by key (offsets in metres).
        given: The keys the user set (the others are at their defaults); the message blames a
            setting the user set.

    Returns:
        None when they fit, else ``(key, message)``: the setting to blame and why.
    """
    rest, contact = values["rest_offset"], values["contact_offset"]
    if rest < contact:
        return None
    if "contact_offset" in given and "rest_offset" not in given:
        return (
            "contact_offset",
            f"must be above rest_offset, got {contact:g} m: rest_offset, left at its default "
            f"{REST_OFFSET_DEFAULT:g} m ({REST_OFFSET_DEFAULT * 1000:g} mm), must stay below "
            f"contact_offset; give a contact_offset above {REST_OFFSET_DEFAULT:g} m, or set "
            f"rest_offset below {contact:g} m too",
        )
    return (
        "rest_offset",
        f"must be below contact_offset ({contact:g} m), got {rest:g}",
    )
