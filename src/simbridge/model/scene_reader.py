"""An MJCF or SDF file's bodies: :func:`parse_scene`, the reader of each format by name
(:mod:`simbridge.model.mjcf`, :mod:`simbridge.model.sdf`; what they share is
:mod:`simbridge.model.scene`)."""

from __future__ import annotations

import os

from simbridge.model.mjcf import parse_mjcf
from simbridge.model.scene import SCENE_FORMATS, SceneBody, resolve_scene_source
from simbridge.model.sdf import parse_sdf

__all__ = ["parse_scene"]


def parse_scene(source: str | os.PathLike[str], kind: str) -> list[SceneBody]:
    """The bodies PyBullet creates from an MJCF or SDF file, in its order. See
    :func:`simbridge.model.mjcf.parse_mjcf` and :func:`simbridge.model.sdf.parse_sdf`.

    Args:
        source: A path, a name on the search path, or the file's text.
        kind: ``"mjcf"`` or ``"sdf"``.

    Returns:
        One :class:`~simbridge.model.scene.SceneBody` per body.

    Raises:
        ValueError: ``kind`` is neither.
        UrdfError: as the format's reader, or the file is found nowhere
            (UrdfNotFoundError).
    """
    if kind not in SCENE_FORMATS:
        raise ValueError(f"kind must be one of {SCENE_FORMATS}, got {kind!r}")
    src = resolve_scene_source(source, kind)
    return parse_mjcf(src) if kind == "mjcf" else parse_sdf(src)
