"""MuJoCo's engine settings: its options and contact parameters users tune.

Imports no engine (read when a profile or a scenario is checked). The defaults are what the
backend builds a world with today (model.py, backend.py): contact pairs with solref
(2 dt, 1), MuJoCo's own solimp, a 1 mm margin; PyBullet's joint-limit rule (motor_rows.py);
MuJoCo's own option values otherwise. The
contact parameters apply to every contact pair the backend makes (robot-robot and self
collision); the options to the world.
Left out: ``integrator`` (the backend integrates with ``mj_Euler`` itself when it splits the
step) and ``iterations`` (the profile's ``solver_iterations``).
"""

from __future__ import annotations

from typing import Any

from simbridge.engine_settings import Setting


def contact_solref(profile: Any) -> tuple[float, float]:
    """The contacts' solref under ``profile``: (2 dt, 1), as stiff as stays stable.

    Args:
        profile: The engine profile (its ``timestep``, in seconds).

    Returns:
        MuJoCo's ``(timeconst, dampratio)``: the time constant in seconds, the damping ratio.
    """
    return (2.0 * float(profile.timestep), 1.0)


SETTINGS = (
    Setting(
        "solref",
        "floats",
        contact_solref,
        "contact reference: (time constant s, damping ratio), or (-stiffness, -damping); "
        "a smaller time constant is a stiffer contact",
        sizes=(2,),
        toward="pybullet.contactERP",
        default_note="[2 * timestep, 1.0]",
    ),
    Setting(
        "solimp",
        "floats",
        (0.9, 0.95, 0.001, 0.5, 2.0),
        "contact impedance (dmin, dmax, width m[, midpoint, power]): how much of the contact's "
        "force acts at each penetration; nearer 1 is harder",
        sizes=(3, 5),
        low=0.0,
        toward="pybullet.globalCFM",
    ),
    Setting(
        "margin",
        "float",
        0.001,
        "distance at which a contact starts (the contact pairs' margin)",
        unit="m",
        low=0.0,
        toward="pybullet.contactSlop",
    ),
    Setting(
        "gap",
        "float",
        0.0,
        "of the margin, the part in which a contact is made but exerts no force",
        unit="m",
        low=0.0,
    ),
    Setting(
        "cone",
        "choice",
        "pyramidal",
        "friction cone: 'pyramidal' (PyBullet-like) or 'elliptic'",
        choices=("pyramidal", "elliptic"),
        toward="pybullet.enableConeFriction",
    ),
    Setting(
        "impratio",
        "float",
        1.0,
        "ratio of frictional to normal impedance (higher: less slip, elliptic cones)",
        low=0.0,
        low_open=True,
    ),
    Setting(
        "noslip_iterations",
        "int",
        0,
        "iterations of the no-slip solver after the main one (0: off); removes creep",
        low=0,
        high=10000,
    ),
    Setting(
        "noslip_tolerance",
        "float",
        1e-6,
        "the no-slip solver stops once its improvement is under this",
        low=0.0,
    ),
    Setting(
        "limit_rule",
        "choice",
        "pybullet",
        "how a joint's position limit acts: 'pybullet' (PyBullet's: no limit until a step "
        "starts at or past it, so a joint passes by up to one step's travel, then is pushed "
        "back at 0.2 of the depth per step) or 'hard' (PhysX's: a joint arriving at its limit "
        "is stopped on it within the step; past it, pushed back as PyBullet's; "
        "backends/mujoco/motor_rows.py)",
        choices=("pybullet", "hard"),
        toward="physx.limit_rule",
    ),
    Setting(
        "solver",
        "choice",
        "Newton",
        "constraint solver",
        choices=("Newton", "CG", "PGS"),
        toward="physx.solver",
    ),
    Setting(
        "tolerance",
        "float",
        1e-8,
        "the solver stops once its improvement is under this",
        low=0.0,
        toward="pybullet.solverResidualThreshold",
    ),
    Setting(
        "ls_iterations",
        "int",
        50,
        "line-search iterations per solver iteration (Newton, CG)",
        low=1,
        high=10000,
    ),
    Setting(
        "ls_tolerance",
        "float",
        0.01,
        "line-search tolerance (Newton, CG)",
        low=0.0,
        low_open=True,
    ),
)
