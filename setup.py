"""The one compiled part: the MuJoCo backend's step loop (backends/mujoco/_mjkernel.c).

It is optional: built against the MuJoCo headers that the ``mujoco`` wheel ships (a build
requirement in pyproject.toml); where it cannot be built (no C compiler), the package installs
without it and the backend steps in Python, with the same results
(tests/backends/mujoco/test_mujoco_kernel.py).
"""

from __future__ import annotations

import importlib.util
import os

from setuptools import Extension, setup


def _mujoco_include() -> list[str]:
    spec = importlib.util.find_spec("mujoco")
    if spec is None or spec.origin is None:
        return []
    include = os.path.join(os.path.dirname(spec.origin), "include")
    return [include] if os.path.isdir(os.path.join(include, "mujoco")) else []


_include = _mujoco_include()
setup(
    ext_modules=[
        Extension(
            "simbridge.backends.mujoco._mjkernel",
            sources=["backends/mujoco/_mjkernel.c"],
            include_dirs=_include,
            extra_compile_args=["-O2", "-std=c11"],
            optional=True,
        )
    ]
    if _include
    else [],
)
