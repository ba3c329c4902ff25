"""The `Sim`: one robot-simulation interface, PyBullet's meaning, any engine.

:mod:`~simbridge.sim.core` holds the `Sim` (construction, lifecycle, loading, stepping); its
other calls live in parts, one job each: :mod:`~simbridge.sim.lookups` (ids, names, tables,
state reads), :mod:`~simbridge.sim.control` (teleports, motor and bound commands),
:mod:`~simbridge.sim.multi_dof` (spherical joints), :mod:`~simbridge.sim.world` (contacts,
``get_state`` and ``set_state``) and :mod:`~simbridge.sim.pictures` (``render``). The argument
checks are :mod:`~simbridge.sim.arguments`, PyBullet's keywords and names
:mod:`~simbridge.sim.keywords` and :mod:`~simbridge.sim.pybullet_names`.
"""

from simbridge.sim.core import DIVERGENCE_CHECKS, Sim

__all__ = ["DIVERGENCE_CHECKS", "Sim"]
