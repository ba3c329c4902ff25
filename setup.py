"""What pyproject.toml cannot say by itself: the package list over the mapped folders, and the
one compiled part, the MuJoCo backend's step loop (backends/mujoco/_mjkernel.c).

Packages: pyproject.toml's ``[tool.setuptools] package-dir`` maps each folder into ``simbridge``
(src/simbridge, backends, compare, robots); every folder with an ``__init__.py`` below one of
them is found here (``find_packages``) and installed under the mapped name, so a new subpackage
cannot be left out of the wheel (tests/test_packaging.py checks it).

The step loop is optional: built against the MuJoCo headers that the ``mujoco`` wheel ships (a
build requirement in pyproject.toml). Where it cannot be built (no C compiler, no headers), the
package installs without it and says so here, at build; the backend then steps in Python with
the same results (tests/backends/mujoco/test_mujoco_kernel.py), about 12x slower, and says so
again when the first MuJoCo Sim is made and in ``simbridge info``. The headers' version is
compiled into the loop (``HEADER_VERSION``); backends/mujoco/kernel.py compares it with the
MuJoCo that runs and falls back, saying so, when they differ.
"""

from __future__ import annotations

import glob
import importlib.util
import os
import sys
import tomllib
from importlib import metadata

from setuptools import Extension, find_packages, setup
from setuptools.command.build_ext import build_ext
from setuptools.errors import BaseError, CCompilerError

HERE = os.path.dirname(os.path.abspath(__file__))
FALLBACK = (
    "the MuJoCo backend will step in Python, about 12x slower, with the same results; "
    "`simbridge info` says which step loop runs"
)


def mapped_roots() -> dict[str, str]:
    """pyproject.toml's ``[tool.setuptools] package-dir``: package name -> folder."""
    with open(os.path.join(HERE, "pyproject.toml"), "rb") as f:
        return dict(tomllib.load(f)["tool"]["setuptools"]["package-dir"])


def packages(roots: dict[str, str]) -> list[str]:
    """Each mapped root and every package found below its folder, under the mapped name."""
    found = []
    for name, folder in roots.items():
        found.append(name)
        found += [f"{name}.{sub}" for sub in find_packages(os.path.join(HERE, folder))]
    return sorted(found)


def _mujoco_include() -> list[str]:
    spec = importlib.util.find_spec("mujoco")
    if spec is None or spec.origin is None:
        return []
    include = os.path.join(os.path.dirname(spec.origin), "include")
    return [include] if os.path.isdir(os.path.join(include, "mujoco")) else []


def _mujoco_release() -> str:
    """The build environment's mujoco release (compiled into the loop as ``MUJOCO_RELEASE``)."""
    try:
        return metadata.version("mujoco")
    except metadata.PackageNotFoundError:
        return "unknown"


def _say(text: str) -> None:
    print(f"simbridge: WARNING: {text}", file=sys.stderr, flush=True)


class BuildStepLoop(build_ext):
    """``build_ext`` that says it when the optional step loop is not built, and why."""

    def build_extension(self, ext: Extension) -> None:
        try:
            super().build_extension(ext)
        except (CCompilerError, BaseError) as exc:  # no compiler, a compile or link error
            _say(f"the compiled step loop ({ext.sources[0]}) was not built ({exc}): {FALLBACK}")

    def copy_extensions_to_source(self) -> None:
        """An editable install copies the loop into the checkout: there, a loop of an older
        build under another file name (``_mjkernel.cpython-311-*.so``, from before the abi3
        build) would be imported before the new one (CPython tries its own suffix first), so it
        is removed."""
        super().copy_extensions_to_source()
        build_py = self.get_finalized_command("build_py")
        for ext in self.extensions:
            package, _, name = ext.name.rpartition(".")
            folder = build_py.get_package_dir(package)
            new = os.path.basename(self.get_ext_filename(ext.name))
            if not os.path.exists(os.path.join(folder, new)):
                continue  # not built (no compiler): nothing replaces the old one
            for old in glob.glob(os.path.join(folder, f"{name}.*")):
                if os.path.basename(old) != new and old.endswith((".so", ".pyd", ".dylib")):
                    os.remove(old)


_include = _mujoco_include()
if not _include:
    _say(
        "no MuJoCo headers in this build environment (the `mujoco` wheel's include/): "
        f"the compiled step loop is not built: {FALLBACK}"
    )
_roots = mapped_roots()
setup(
    packages=packages(_roots),
    cmdclass={"build_ext": BuildStepLoop},
    # the step loop keeps to CPython 3.11's limited API: one wheel, cp311-abi3, for 3.11 and later
    options={"bdist_wheel": {"py_limited_api": "cp311"}},
    ext_modules=[
        Extension(
            "simbridge.backends.mujoco._mjkernel",
            sources=["backends/mujoco/_mjkernel.c"],
            include_dirs=_include,
            define_macros=[
                ("SIMBRIDGE_MUJOCO_RELEASE", f'"{_mujoco_release()}"'),
                ("Py_LIMITED_API", "0x030B0000"),
            ],
            py_limited_api=True,
            extra_compile_args=["-O2", "-std=c11"],
            optional=True,
        )
    ]
    if _include
    else [],
)
