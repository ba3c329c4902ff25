"""The PhysX backend: `Sim` on PhysX 5 through SAPIEN 3 with PyBullet's semantics. One job per
module:

=================  ======================================================================
``backend``        :class:`PhysxBackend`, the world and the step
``model``          the URDF built as one PhysX articulation (or a static actor) per body
``robots``         what the backend keeps of each robot, its motors at load
``reads``          the joint table, link, base and joint states, teleports
``commands``       PyBullet's motors as PhysX joint drives, and the commands in force
``contacts``       contact points in PyBullet's terms
``world``          the whole world's state: snapshot and restore
``ball``           spherical joints as three revolute joints
``limits``         PyBullet's joint-limit rows for a joint past its limit
``combine``        PyBullet's product friction rule on PhysX materials
``window``         SAPIEN's window for ``gui=True``
``window_process`` the window's own process
``inspect``        read-only access to a Sim's SAPIEN scene and articulations, for tests
=================  ======================================================================
"""

from .backend import PhysxBackend

__all__ = ["PhysxBackend"]
