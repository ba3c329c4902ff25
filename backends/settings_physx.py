"""PhysX's engine settings (SAPIEN 3): the scene's and the shapes' knobs users tune.

Imports no engine (read when a profile or a scenario is checked). The defaults are what the
backend builds a world with today (backend.py, model.py): PGS, one velocity iteration, a 1 cm
contact offset, a 0.5 mm rest offset, bounce threshold 2 m/s, no depenetration speed cap, and
SAPIEN's own scene flags. Left out: position iterations (the profile's ``solver_iterations``).
"""

from __future__ import annotations

from typing import Any

from simbridge.engine_settings import Setting

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
        0.0005,
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


def check_together(values: dict[str, Any]) -> tuple[str, str] | None:
    """PhysX makes a shape's contacts within its contact offset and rests it at its rest
    offset: the rest offset must be below the contact offset."""
    if values["rest_offset"] >= values["contact_offset"]:
        return (
            "rest_offset",
            f"must be below contact_offset ({values['contact_offset']:g} m), "
            f"got {values['rest_offset']:g}",
        )
    return None
