"""The modules that moved into rooms (``simbridge.urdf`` is now ``simbridge.model.urdf``), still
importable by their old names for one release, with a :class:`DeprecationWarning` naming the
new one. The old name is the very module object of the new (``sys.modules`` holds both)."""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.util
import sys
import warnings
from importlib.machinery import ModuleSpec
from types import ModuleType

__all__ = ["MOVED", "install"]

MOVED = {
    **{
        old: f"model.{old}"
        for old in (
            "urdf",
            "urdf_xml",
            "urdf_model",
            "urdf_source",
            "mjcf",
            "mjcf_reader",
            "sdf",
            "scene",
            "meshes",
            "inertia",
            "joint_table",
            "load_options",
            "build_plan",
        )
    },
    "scene_files": "model.scene_reader",
    "sim_control": "sim.control",
    "sim_lookups": "sim.lookups",
    "sim_multi_dof": "sim.multi_dof",
    "sim_render": "sim.pictures",
    "sim_state": "sim.world",
    "state": "sim.state_check",
    "contacts": "sim.contacts",
    "arguments": "sim.arguments",
    "keywords": "sim.keywords",
    "pybullet_names": "sim.pybullet_names",
    "multi_dof": "spherical",
    **{
        f"cli_{old}": f"cli.{old}"
        for old in ("args", "cache", "info", "settings", "study", "usage")
    },
}
"""Old module name under ``simbridge.`` -> its new name under ``simbridge.``."""


class _Loader(importlib.abc.Loader):
    def __init__(self, new: str) -> None:
        self.new = new

    def create_module(self, spec: ModuleSpec) -> ModuleType:
        warnings.warn(
            f"{spec.name} moved to {self.new}; the old name goes in the next release",
            DeprecationWarning,
            stacklevel=2,
        )
        module = importlib.import_module(self.new)
        sys.modules[spec.name] = module
        return module

    def exec_module(self, module: ModuleType) -> None:
        """The new module ran when it was imported; nothing more to run."""


class _Finder(importlib.abc.MetaPathFinder):
    def find_spec(self, fullname: str, path: object, target: object = None) -> ModuleSpec | None:
        prefix, _, old = fullname.partition(".")
        if prefix != "simbridge" or old not in MOVED:
            return None
        return importlib.util.spec_from_loader(fullname, _Loader(f"simbridge.{MOVED[old]}"))


def install() -> None:
    """Put the finder of moved modules on :data:`sys.meta_path` (once)."""
    if not any(isinstance(f, _Finder) for f in sys.meta_path):
        sys.meta_path.append(_Finder())
