"""The MuJoCo backend: `Sim` on MuJoCo 4 with PyBullet's semantics. One job per module:

=================  ======================================================================
``backend``        :class:`MujocoBackend`, the ``Backend`` methods; engine errors become the
                   Sim's errors here
``model``          the URDF built into MuJoCo's ``MjSpec`` (bodies, joints, geoms, contact
                   pairs)
``robots``         the robots and everything derived from one compile (:class:`Compiled`)
``reads``          the joint table, link, base and joint states, teleports
``commands``       the motor commands, bound commands and the commands in force
``contacts``       contact points in PyBullet's terms
``world``          the whole world's state: snapshot, restore, the time
``motor_rows``     PyBullet's motors and joint limits as MuJoCo rows (the motor table)
``solve``          those rows made exact: the contact-free solve and the polish
``damping``        PyBullet's link damping and joint speed clamp
``loop``           the step loop in Python, the reference of the compiled one
``kernel``         loads the compiled step loop (``_mjkernel.c``), says why when it cannot
``window``         MuJoCo's passive viewer for ``gui=True``
``window_process`` the viewer's own process
``inspect``        read-only access to a Sim's MuJoCo model and data, for tests and debugging
=================  ======================================================================
"""

from .backend import MujocoBackend

__all__ = ["MujocoBackend"]
