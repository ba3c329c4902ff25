"""The replay's robots as meshes and poses (:mod:`.replay`): each link's visual geometry read
from the robot's URDF as triangle meshes (boxes, cylinders, spheres, capsules and mesh files),
each link's pose at a recorded row (:func:`link_poses`), the points a body spans
(:func:`body_points`) and the camera that frames them (:func:`camera_view`). No viser here."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..run.trajectory import BodyTrajectory, Trajectory

__all__ = [
    "CAMERA_FILL",
    "CAMERA_FOV",
    "CAMERA_SIDE",
    "LinkVisual",
    "body_points",
    "camera_view",
    "link_poses",
    "link_visuals",
    "read_model",
    "urdf_sources",
    "quat_wxyz",
]


@dataclass
class LinkVisual:
    link: int  # -1: base
    vertices: np.ndarray  # (n, 3) float32, in the link frame
    faces: np.ndarray  # (m, 3) uint32
    rgba: tuple[float, float, float, float]


def urdf_sources(tr: Trajectory) -> list[str | None]:
    """Each body's URDF file, in ``tr.bodies`` order (None where it was not a URDF file)."""
    bodies = tr.manifest.get("bodies", {}) if isinstance(tr.manifest, dict) else {}
    keyed = sorted(bodies.items(), key=lambda kv: int(kv[0]))
    out: list[str | None] = []
    for _, m in keyed[: len(tr.bodies)]:
        src = m.get("source") if isinstance(m, dict) else None
        out.append(src if isinstance(src, str) and src.lower().endswith(".urdf") else None)
    return out + [None] * (len(tr.bodies) - len(out))


def read_model(source: str | None) -> Any:
    if source is None or not Path(source).is_file():
        return None
    from simbridge.model.urdf import parse_urdf, resolve_source

    try:
        return parse_urdf(resolve_source(source))
    except Exception:  # a file moved or changed since the run: spheres instead
        return None


def _geometry_mesh(g: Any) -> tuple[np.ndarray, np.ndarray] | None:
    """Vertices and triangles of one ``<visual>`` geometry in its own frame (None: nothing to
    draw: a plane, an unreadable mesh)."""
    if g.kind == "box":
        return _box(np.asarray(g.size, dtype=float))
    if g.kind == "cylinder":
        return _cylinder(g.size[0], g.size[1])
    if g.kind == "capsule":
        return _capsule(g.size[0], g.size[1])
    if g.kind == "sphere":
        return _sphere(g.size[0])
    if g.kind == "mesh" and g.mesh_path is not None:
        from simbridge.model.meshes import read_mesh

        try:
            data = read_mesh(g.mesh_path)
        except Exception:  # unreadable: left out, as the engines leave it
            return None
        scale = np.asarray(g.size or (1.0, 1.0, 1.0), dtype=float)
        return np.asarray(data.vertices, dtype=float) * scale, np.asarray(data.faces)
    return None


def _box(size: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
    faces = np.array(
        [[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
         [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]]
    )  # fmt: skip
    return corners * size / 2, faces


def _lathe(profile: np.ndarray, sections: int = 24) -> tuple[np.ndarray, np.ndarray]:
    """A surface of revolution about z: ``profile`` (k, 2) rows of (radius, z), bottom to
    top, the first and last of radius 0 (the poles)."""
    a = np.linspace(0, 2 * np.pi, sections, endpoint=False)
    rings = [
        np.stack([r * np.cos(a), r * np.sin(a), np.full(sections, z)], axis=1) for r, z in profile
    ]
    v = np.concatenate(rings)
    faces = []
    for i in range(len(profile) - 1):
        for j in range(sections):
            a0, a1 = i * sections + j, i * sections + (j + 1) % sections
            b0, b1 = a0 + sections, a1 + sections
            faces += [[a0, a1, b1], [a0, b1, b0]]
    return v, np.asarray(faces)


def _cylinder(radius: float, length: float) -> tuple[np.ndarray, np.ndarray]:
    h = length / 2
    return _lathe(np.array([[0, -h], [radius, -h], [radius, h], [0, h]]))


def _sphere(radius: float) -> tuple[np.ndarray, np.ndarray]:
    t = np.linspace(-np.pi / 2, np.pi / 2, 13)
    return _lathe(np.stack([radius * np.cos(t), radius * np.sin(t)], axis=1))


def _capsule(radius: float, length: float) -> tuple[np.ndarray, np.ndarray]:
    t = np.linspace(0, np.pi / 2, 7)
    cap = np.stack([radius * np.cos(t), radius * np.sin(t)], axis=1)
    low = (cap * [1, -1])[::-1] + [0, -length / 2]
    high = cap + [0, length / 2]
    return _lathe(np.concatenate([low, high]))


def link_visuals(model: Any) -> list[LinkVisual]:
    from simbridge.transforms import quat_to_matrix

    out = []
    for link in model.links:
        for g in link.visuals:
            mesh = _geometry_mesh(g)
            if mesh is None or len(mesh[1]) == 0:
                continue
            v, f = mesh
            r = quat_to_matrix(g.origin_quat)
            v = v @ r.T + np.asarray(g.origin_xyz)
            rgba = g.rgba if g.rgba is not None else (0.7, 0.7, 0.7, 1.0)
            out.append(LinkVisual(link.index, v.astype(np.float32), f.astype(np.uint32), rgba))
    return out


def _quat_matrices(q: np.ndarray) -> np.ndarray:
    """(T, 3, 3) rotation matrices of (T, 4) quaternions (x, y, z, w)."""
    q = q / np.linalg.norm(q, axis=1, keepdims=True)
    x, y, z, w = q.T
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], -1),
            np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], -1),
            np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1),
        ],
        axis=1,
    )


def quat_wxyz(r: np.ndarray) -> np.ndarray:
    """(T, 4) quaternions (w, x, y, z) of (T, 3, 3) rotation matrices."""
    from scipy.spatial.transform import Rotation

    xyzw = Rotation.from_matrix(r).as_quat()
    return np.concatenate([xyzw[:, 3:], xyzw[:, :3]], axis=1)


def link_poses(
    model: Any, b: BodyTrajectory, rows: np.ndarray
) -> dict[int, tuple[np.ndarray, np.ndarray]]:
    """Every link's URDF frame at ``rows``: {link index (-1 the base): (positions (F, 3),
    rotation matrices (F, 3, 3))}, from the recorded base frame and joint positions along the
    model's joints (a spherical joint's turn is not recorded: drawn unturned)."""
    from simbridge.transforms import quat_to_matrix

    frames = {-1: (b.base_position[rows], _quat_matrices(b.base_orientation[rows]))}
    column = {int(j): k for k, j in enumerate(np.asarray(b.joint_indices))}
    for joint in model.joints:
        p_pos, p_rot = frames[model.parent_index(joint)]
        r_o = quat_to_matrix(joint.origin_quat)
        rot = p_rot @ r_o
        pos = p_pos + p_rot @ np.asarray(joint.origin_xyz)
        k = column.get(joint.index)
        if k is not None and joint.type in ("revolute", "continuous", "prismatic"):
            q = b.joint_positions[rows, k]
            axis = np.asarray(joint.axis, dtype=float)
            axis = axis / (np.linalg.norm(axis) or 1.0)
            if joint.type == "prismatic":
                pos = pos + (rot @ axis) * q[:, None]
            else:
                from scipy.spatial.transform import Rotation

                rot = rot @ Rotation.from_rotvec(axis[None, :] * q[:, None]).as_matrix()
        frames[joint.index] = (pos, rot)
    return frames


def _boxes(model: Any) -> list[tuple[int, np.ndarray]]:
    """Each of ``model``'s visuals as its link and the 8 corners of its box (link frame)."""
    out = []
    for v in link_visuals(model):
        lo, hi = v.vertices.min(axis=0), v.vertices.max(axis=0)
        corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                            for z in (lo[2], hi[2])], dtype=float)  # fmt: skip
        out.append((v.link, corners))
    return out


_MODELS: dict[tuple[str, int, int], tuple[Any, list[tuple[int, np.ndarray]]]] = {}
"""URDF models and their visuals' boxes by file (path, modification time, size): the key
frames and the replay of one report read a robot's meshes once."""


def _model_boxes(source: str | None) -> tuple[Any, list[tuple[int, np.ndarray]]]:
    if source is None:
        return None, []
    try:
        st = Path(source).stat()
    except OSError:
        return None, []
    key = (source, st.st_mtime_ns, st.st_size)
    if key not in _MODELS:
        model = read_model(source)
        if len(_MODELS) >= 16:
            _MODELS.clear()
        _MODELS[key] = (model, _boxes(model) if model is not None else [])
    return _MODELS[key]


def body_points(tr: Trajectory, name: str, rows: np.ndarray) -> np.ndarray:
    """(F, P, 3) m, world: points that bound body ``name`` of ``tr`` at ``rows`` as it is
    drawn: the corners of its ``<visual>`` geometries' boxes, posed along the URDF's joints
    from the recorded base and joint positions; where its file is no URDF (an MJCF body) or
    has no visual, its links' centres of mass with a margin of a tenth of their spread and
    2 cm each way."""
    rows = np.asarray(rows, dtype=int)
    names = list(tr.bodies)
    b = tr.bodies[name]
    model, boxes = _model_boxes(urdf_sources(tr)[names.index(name)])
    if model is not None and boxes:
        frames = link_poses(model, b, rows)
        parts = []
        for link, corners in boxes:
            pos, rot = frames[link]  # (F, 3), (F, 3, 3)
            parts.append(np.einsum("fij,pj->fpi", rot, corners) + pos[:, None, :])
        return np.concatenate(parts, axis=1)
    links = np.asarray(b.link_positions[rows], dtype=float)  # (F, L, 3)
    spread = np.ptp(links, axis=1).max(axis=1, initial=0.0)  # (F,)
    pad = (0.1 * spread + 0.02)[:, None, None]
    steps = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
    return (links[:, :, None, :] + pad[..., None] * steps[None, None]).reshape(len(rows), -1, 3)


CAMERA_FOV = 75.0
"""Degrees: the replay viewer's vertical field of view (viser's)."""


CAMERA_SIDE = (0.8, -1.4, 0.7)
"""The direction the replay's camera looks from (towards the robots), before its length."""


CAMERA_FILL = 0.8
"""The share of the view's height the robots' bounding sphere takes."""


def camera_view(
    extent: list[np.ndarray],
) -> tuple[tuple[float, float, float], tuple[float, float, float]] | None:
    """Where the replay's camera looks and stands: at the middle of the box that holds the
    moving bodies' drawn points ``extent`` (each (F, P, 3), :func:`body_points`) over the run,
    and back along :data:`CAMERA_SIDE` so that the box's bounding sphere takes
    :data:`CAMERA_FILL` of the view's height. The box spans the middle 90% of the points along
    each axis (a robot thrown far leaves the view for a while rather than shrinking the others
    to specks), the start's points always in it. None without a point."""
    pts = [x.reshape(-1, 3) for x in extent if x.size]
    if not pts:
        return None
    every = np.concatenate(pts)
    every = every[np.isfinite(every).all(axis=1)]
    if not len(every):
        return None
    start = np.concatenate([x[0] for x in extent if x.size])
    start = start[np.isfinite(start).all(axis=1)]
    lo, hi = np.percentile(every, 5, axis=0), np.percentile(every, 95, axis=0)
    if len(start):
        lo, hi = np.minimum(lo, start.min(axis=0)), np.maximum(hi, start.max(axis=0))
    centre = (lo + hi) / 2
    radius = max(float(np.linalg.norm(hi - lo)) / 2, 0.05)
    half = math.radians(CAMERA_FOV) / 2
    distance = radius / math.sin(CAMERA_FILL * half)
    side = np.asarray(CAMERA_SIDE, dtype=float)
    eye = centre + side / np.linalg.norm(side) * distance
    return _point(centre), _point(eye)


def _point(x: np.ndarray) -> tuple[float, float, float]:
    return float(x[0]), float(x[1]), float(x[2])
