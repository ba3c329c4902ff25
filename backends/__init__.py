"""The engines behind `Sim`: one package per engine, the same file for the same part.

Each package implements :class:`simbridge.backend.Backend` and is registered lazily in
``simbridge.registry`` (``"simbridge.backends.<engine>:<Class>"``). As gz-physics keeps one file
per feature per engine, a part lives in a file of the same name in every package; a fourth
engine makes these files (a part its engine does not need is left out, and says so):

======================  =====================================================================
file                    the part
======================  =====================================================================
``__init__.py``         the backend class re-exported; the package's modules listed
``backend.py``          the Backend class: the world's lifecycle (load, remove, reset, close),
                        the step, the manifest; the parts below are its mixins
``model.py``            the engine's model built from the build plan (PyBullet: the file
                        handed to its own loader, the profile applied to what it built)
``robots.py``           what the backend keeps of each robot between calls (PyBullet: the
                        per-body record ``_Body`` in ``common.py``)
``reads.py``            state reads and resets: joint table, link, base and joint states
``commands.py``         motor and joint commands, and the commands in force (``joint_commands``,
                        ``set_joint_commands``, spherical states; PhysX's spherical ones in
                        ``ball.py``, PyBullet's records of the commands in ``records.py``)
``contacts.py``         ``contact_points`` in PyBullet's terms
``world.py``            the whole world's state: ``snapshot``, ``restore`` (and ``set_time``)
``window.py``           the window of ``Sim(gui=True)``
``window_process.py``   the window's own process, where it runs in one (MuJoCo, PhysX)
``inspect.py``          the one door into the internals, for tests and benchmarks
======================  =====================================================================

Parts with no counterpart keep a descriptive name: PyBullet's ``output.py`` (its printout as log
records), ``common.py`` (the per-body record and checks), ``records.py`` (the commands given,
PyBullet having no getter for them), ``scene.py`` (its MJCF/SDF loaders), ``render.py``
(TinyRenderer pictures); MuJoCo's ``motor_rows.py`` (the motors as MuJoCo rows), ``solve.py``,
``damping.py``, ``loop.py``, ``kernel.py`` and ``_mjkernel.c`` (the step loop); PhysX's
``ball.py`` (spherical joints as three revolutes), ``limits.py`` (PyBullet's limit rows),
``combine.py`` (the product friction rule). Beside the packages: ``settings_<engine>.py``, the
engine settings a profile may set, and ``locking.py``, the one-call-at-a-time guard they share.
"""
