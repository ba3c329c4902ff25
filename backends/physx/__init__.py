"""The PhysX backend: `Sim` on PhysX 5 through SAPIEN 3 with PyBullet's semantics. One job per
module:

=============  ==========================================================================
``backend``    :class:`PhysxBackend`, the world and the step
``model``      the URDF built as one PhysX articulation (or a static actor) per body
``world``      what the backend keeps of each robot, its motors at load
``motors``     PyBullet's motors as PhysX joint drives
``state``      the joint table, link, base and joint states, teleports
``contacts``   contact points in PyBullet's terms
``inspect``    read-only access to a Sim's SAPIEN scene and articulations, for tests
=============  ==========================================================================
"""

from .backend import PhysxBackend

__all__ = ["PhysxBackend"]
