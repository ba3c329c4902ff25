"""The `Sim`: one robot-simulation interface, PyBullet's meaning, any engine.

:mod:`~simbridge.sim.core` holds the `Sim`: its public methods, each documented, over one
:class:`~simbridge.sim.shared.Shared` object (the backend, the bodies' tables, the bound
commands in force). Its parts are functions taking that object, one job each:
:mod:`~simbridge.sim.lookups` (bodies, joint and link indices, joint-index arrays),
:mod:`~simbridge.sim.loading` (URDF, MJCF, SDF), :mod:`~simbridge.sim.control` (teleports,
bound commands), :mod:`~simbridge.sim.multi_dof` (spherical joints), :mod:`~simbridge.sim.world`
(contacts, ``get_state`` and ``set_state``), :mod:`~simbridge.sim.pictures` (``render``) and
:mod:`~simbridge.sim.native` (an MJCF read as MuJoCo reads it, and MuJoCo's own calls). The
argument checks are :mod:`~simbridge.sim.arguments`, PyBullet's keywords and names
:mod:`~simbridge.sim.keywords` and :mod:`~simbridge.sim.pybullet_names`.
"""

from simbridge.sim.core import DIVERGENCE_CHECKS, Sim

__all__ = ["DIVERGENCE_CHECKS", "Sim"]
