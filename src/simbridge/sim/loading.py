"""The `Sim`'s loading: URDF, MJCF and SDF files read into build plans
(:mod:`simbridge.model`), handed to the backend, and each body's table kept. Functions of the
Sim's :class:`~simbridge.sim.shared.Shared` state."""

from __future__ import annotations

import os
from dataclasses import replace
from typing import TYPE_CHECKING, Any

from simbridge.sim.arguments import flag, quat, vec, within
from simbridge.sim.native import refuse_after_native
from simbridge.sim.shared import BodyTable, Shared

if TYPE_CHECKING:
    from simbridge.model.urdf_model import UrdfModel

__all__ = ["load_scene", "load_urdf"]


def load_urdf(
    s: Shared,
    source: str | os.PathLike[str],
    base_position: Any,
    base_orientation: Any,
    fixed_base: Any,
    options: dict[str, Any],
) -> int:
    """Load a robot (:meth:`simbridge.Sim.load_urdf`).

    Args:
        s: the Sim's shared state.
        source, base_position, base_orientation, fixed_base: as
            :meth:`simbridge.Sim.load_urdf`'s.
        options: its ``global_scaling``, ``self_collision``, ``inertia_source`` and
            ``merge_fixed_links``, by name.

    Returns:
        The body id.

    Raises:
        UrdfNotFoundError, UrdfParseError, UrdfStructureError, MeshNotFoundError,
        UnsupportedJointError: the message names the file, the line and the element.
        InvalidArgumentError: a bad pose or option.
        BackendUnsupportedError: the world holds an MJCF read with semantics='mujoco'.
    """
    refuse_after_native(s, "load_urdf")
    pos = vec(base_position, 3, "base_position")
    within(pos, "base_position")
    orn = quat(base_orientation, "base_orientation", normalise=True)
    fixed = flag(fixed_base, "fixed_base")
    # loaded on first use
    from simbridge.model.load_options import apply_load_options, load_options
    from simbridge.model.urdf import (
        check_file_inertia,
        parse_urdf,
        resolve_source,
        warn_missing_inertials,
    )

    chosen = load_options(s.backend.profile, **options)
    model = parse_urdf(resolve_source(source))
    warn_missing_inertials(model)
    if chosen.inertia_source == "file":
        check_file_inertia(model)
    model = apply_load_options(model, chosen, bool(fixed))
    s.end_commands("load_urdf changed the world")
    body = s.backend.load(model, pos, orn, bool(fixed), chosen)  # type: ignore[arg-type]
    _record(
        s,
        body,
        model,
        {
            "source": model.source.display_name,
            "base_position": pos,
            "base_orientation": orn,
            "fixed_base": bool(fixed),
            **chosen.as_dict(),
        },
    )
    return body


def load_scene(
    s: Shared, source: str | os.PathLike[str], kind: str, self_collision: bool | str | None
) -> tuple[int, ...]:
    """Load every body of an MJCF or SDF file (:meth:`simbridge.Sim.load_mjcf`,
    :meth:`simbridge.Sim.load_sdf`).

    Args:
        s: the Sim's shared state.
        source: a file path, a name on the search path, or the file's text.
        kind: ``"mjcf"`` or ``"sdf"``.
        self_collision: as ``load_urdf``'s; None: the profile's.

    Returns:
        The body ids, in the file's order.

    Raises:
        UrdfNotFoundError, UrdfParseError, UrdfStructureError, MeshNotFoundError,
        UnsupportedJointError: the message names the file, the line and the element.
        BackendUnsupportedError: the world holds an MJCF read with semantics='mujoco'.
    """
    from simbridge.model.load_options import load_options
    from simbridge.model.scene_reader import parse_scene

    refuse_after_native(s, f"load_{kind}")
    options = load_options(s.backend.profile, self_collision=self_collision)
    # PyBullet's MJCF and SDF importers take the collision-box inertia (loadSDF has no flag
    # for the file's; an MJCF body's file inertia is MuJoCo's to compute)
    options = replace(options, inertia_source="collision_aabb")
    bodies = parse_scene(source, kind)
    s.end_commands(f"load_{kind} changed the world")
    ids = s.backend.load_scene(bodies, options)
    for body, model in zip(ids, bodies, strict=True):
        _record(
            s,
            body,
            model,
            {
                "source": model.source.display_name,
                "format": kind,
                "body_index": model.body_index,
                "base_position": model.base_position,
                "base_orientation": model.base_orientation,
                "fixed_base": model.base.inertial.mass == 0.0,
                **options.as_dict(),
                "ignored": list(model.ignored),
            },
        )
    return tuple(ids)


def _record(s: Shared, body: int, model: UrdfModel, load: dict[str, Any]) -> None:
    """Keep a loaded body's names and indices (from the backend's joint table) and how it
    was loaded (``load``: the manifest's entry)."""
    names = [j.name for j in model.joints]
    links = [j.child for j in model.joints]
    types = [s.backend.joint_info(body, i).type for i in range(len(names))]
    s.bodies[body] = BodyTable(
        model.name,
        names,
        links,
        types,
        {n: i for i, n in enumerate(names)},
        {n: i for i, n in enumerate(links)} | {model.base.name: -1},
        load=load,
    )
