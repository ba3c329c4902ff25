"""The PyBullet backend: `Sim` on PyBullet, the reference semantics. One job per module:

=============  ==========================================================================
``backend``    :class:`PyBulletBackend`, the world's lifecycle (connect, load, remove,
               reset, close) and stepping with its divergence probe
``model``      a robot's file handed to PyBullet's loader, the profile applied to it
``reads``      the state reads and resets
``commands``   the motor commands and the commands in force
``contacts``   contact points (PyBullet's own)
``world``      the whole world's state: snapshot (``saveState``), restore, the time
``records``    the commands given, kept per body (PyBullet has no getter for them)
``output``     PyBullet's printout classified into log records (and the one ``import
               pybullet``, its banner captured)
``common``     what they share: the per-body record, the busy guard, the checks made
               before PyBullet is given a file or a display
``scene``      MJCF/SDF files
``render``     pictures of the world (TinyRenderer, on the CPU)
``window``     PyBullet's own window for ``gui=True``
``inspect``    read-only access to a Sim's PyBullet client, for tests and debugging
=============  ==========================================================================
"""

from .backend import PyBulletBackend

__all__ = ["PyBulletBackend"]
