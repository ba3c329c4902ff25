"""The model: robot files read into engine-neutral descriptions, before any engine is touched.

- URDF: :mod:`~simbridge.model.urdf` (parsing and validation, as PyBullet reads it), its text
  and XML (:mod:`~simbridge.model.urdf_xml`), the parsed robot (:mod:`~simbridge.model.urdf_model`)
  and where it comes from (:mod:`~simbridge.model.urdf_source`).
- MJCF and SDF as PyBullet's ``loadMJCF`` and ``loadSDF`` read them: :mod:`~simbridge.model.mjcf`
  (with its reader :mod:`~simbridge.model.mjcf_reader`), :mod:`~simbridge.model.sdf`, the bodies
  they make (:mod:`~simbridge.model.scene`) and the reader of either
  (:mod:`~simbridge.model.scene_reader`).
- What every engine's builder needs: meshes (:mod:`~simbridge.model.meshes`), mass properties
  (:mod:`~simbridge.model.inertia`), the joint table (:mod:`~simbridge.model.joint_table`),
  ``loadURDF``'s options (:mod:`~simbridge.model.load_options`) and, from all of them, one
  robot's build plan (:mod:`~simbridge.model.build_plan`).

This floor imports the interface modules (exceptions, types, transforms, profiles) and nothing
of :mod:`simbridge.sim`, :mod:`simbridge.cli`, the backends or compare.
"""
