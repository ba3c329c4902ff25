"""The PyBullet backend: `Sim` on PyBullet, the reference semantics. One job per module:

=============  ==========================================================================
``backend``    :class:`PyBulletBackend`, the world's lifecycle (connect, load, remove,
               reset, close) and stepping with its divergence probe
``reads``      the state reads and resets, contacts and snapshots
``commands``   the motor commands and the commands in force
``output``     PyBullet's printout classified into log records (and the one ``import
               pybullet``, its banner captured)
``common``     what they share: the per-body record, the busy guard, the checks made
               before PyBullet is given a file or a display
``state``      the commands' records and saved states
``scene``      MJCF/SDF files
``render``     pictures of the world (TinyRenderer, on the CPU)
``inspect``    read-only access to a Sim's PyBullet client, for tests and debugging
=============  ==========================================================================
"""

from .backend import PyBulletBackend

__all__ = ["PyBulletBackend"]
