"""URDF robots shipped with simbridge (package data).

``r2d2.urdf`` and ``plane.urdf`` (with their meshes) come from pybullet_data so the main job needs
nothing else; the others are small test robots with hand-checked inertias.
"""

from pathlib import Path

ROBOTS_DIR = Path(__file__).resolve().parent


def path(name: str) -> Path:
    """Absolute path of a shipped robot file (``"r2d2.urdf"``)."""
    return ROBOTS_DIR / name
