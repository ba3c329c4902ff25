"""``simbridge info``: the lines a bug report needs. How simbridge is installed (editable from a
checkout, or a wheel) and where it is imported from, which engines are installed and their
versions, which MuJoCo step loop runs (the compiled one and the MuJoCo it was built against, or
the Python one and why), whether windows can open (an X display; a Vulkan driver for PhysX's),
what decides the last bits of a result on this processor, and the study cache's place and size.

The engines are not imported here: their versions are their distributions' (the registry's
``engine_dists``), and what a backend says of its own build comes from the backend's module
(its registration's ``describe``: MuJoCo's step loop), as a Sim would load it.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
from collections.abc import Callable
from importlib import metadata
from pathlib import Path
from typing import Any

__all__ = ["add_command", "info_lines", "described", "install_line", "display_lines"]


def add_command(sub: Any, verbose: Callable[[argparse.ArgumentParser], None]) -> None:
    """Add ``simbridge info`` (its parser's ``handler`` set).

    Args:
        sub: The top-level parser's subparsers.
        verbose: Adds ``--verbose`` to a parser.
    """
    p = sub.add_parser(
        "info",
        help="what is installed and how it runs here: the lines a bug report needs",
        description="Print how simbridge is installed (editable or a wheel), the engines "
        "installed and their versions, the MuJoCo step loop in use (compiled, and the MuJoCo it "
        "was built against, or Python and why), whether windows can open (X, Vulkan), what decides "
        "the last bits of results on this processor, and the study cache's folder and size.",
    )
    verbose(p)
    p.set_defaults(handler=_info)


def _version(dist: str) -> str | None:
    try:
        return metadata.version(dist)
    except metadata.PackageNotFoundError:
        return None


def described(name: str) -> str | None:
    """What a backend says of how it runs here (its registration's ``describe``).

    Args:
        name: A registered backend's name.

    Returns:
        Its line, or None where it says nothing.
    """
    from importlib import import_module

    from simbridge.registry import backend_spec

    target = backend_spec(name).describe
    if not target:
        return None
    module, _, function = target.partition(":")
    return str(getattr(import_module(module), function)())


def install_line(dist_name: str = "simbridge") -> str:
    """How simbridge is installed here, read from its distribution's metadata (PEP 610's
    ``direct_url.json``): editable from a checkout, a wheel (from an index, a file or a folder
    built into one), or not installed at all (imported from a folder on the path).

    Args:
        dist_name: The distribution to read (``simbridge``; another name in tests).

    Returns:
        The ``install:`` line, ending with the folder ``import simbridge`` resolves to.
    """
    import simbridge

    where = Path(simbridge.__file__).resolve().parent
    try:
        dist = metadata.distribution(dist_name)
    except metadata.PackageNotFoundError:
        return f"install: none (no {dist_name} distribution found); imported from {where}"
    direct = json.loads(dist.read_text("direct_url.json") or "{}")
    url = str(direct.get("url", ""))
    source = url.removeprefix("file://") if url.startswith("file://") else url
    if direct.get("dir_info", {}).get("editable"):
        kind = f"editable, from the checkout {source}"
    elif "archive_info" in direct:
        kind = f"a wheel, from {source}"
    elif "dir_info" in direct:
        kind = f"a wheel built from the folder {source}"
    else:
        kind = "a wheel, from a package index"
    return f"install: {kind}; imported from {where}"


def display_lines(env: dict[str, str] | None = None) -> list[str]:
    """Whether ``gui=True`` can open a window here: the X display and its socket, and for PhysX's
    window the Vulkan drivers installed (it needs VK_KHR_external_semaphore_fd, which Debian 12's
    lavapipe 22.3.6 lacks and Mesa 25's has; checked when a window opens).

    Args:
        env: The environment to read (default: ``os.environ``).

    Returns:
        The lines ``simbridge info`` prints about windows.
    """
    env = dict(os.environ) if env is None else env
    display = env.get("DISPLAY", "")
    if not display:
        x = "no DISPLAY: gui=True needs an X server (e.g. Xvfb :99, then DISPLAY=:99)"
    else:
        number = display.rpartition(":")[2].partition(".")[0]
        socket = Path(f"/tmp/.X11-unix/X{number}")
        local = display.startswith(":")
        seen = "its socket found" if socket.exists() else "no socket for it in /tmp/.X11-unix"
        x = f"DISPLAY={display}" + (f" ({seen})" if local else "")
    icds = sorted(
        p.name
        for folder in ("/usr/share/vulkan/icd.d", "/etc/vulkan/icd.d")
        if Path(folder).is_dir()
        for p in Path(folder).glob("*.json")
    )
    mesa = _deb_version("mesa-vulkan-drivers")
    vulkan = ", ".join(icds) if icds else "no Vulkan driver found (PhysX's window cannot open)"
    if mesa:
        vulkan += f"; mesa-vulkan-drivers {mesa}"
    return [f"windows: {x}", f"  physx's window: Vulkan drivers: {vulkan}"]


def _deb_version(package: str) -> str | None:
    """The installed version of a Debian package, read from dpkg's status file (None: not
    installed, or not a Debian system)."""
    status = Path("/var/lib/dpkg/status")
    try:
        text = status.read_text(encoding="utf-8", errors="replace")
    except OSError:
        return None
    for block in text.split("\n\n"):
        if f"Package: {package}\n" in block + "\n" and "Status: install ok installed" in block:
            for line in block.splitlines():
                if line.startswith("Version: "):
                    return line.removeprefix("Version: ")
    return None


def _numerics() -> list[str]:
    """What decides a result's last bits here (tests/_machine.py's keys)."""
    try:
        from numpy._core._multiarray_umath import (  # type: ignore[import-not-found]
            __cpu_dispatch__,
            __cpu_features__,
        )
    except ImportError:  # another numpy layout
        targets = "unknown"
    else:
        targets = " ".join(f for f in __cpu_dispatch__ if __cpu_features__.get(f)) or "none"
    flags: set[str] = set()
    try:
        for line in Path("/proc/cpuinfo").read_text(encoding="utf-8").splitlines():
            if line.startswith("flags"):
                flags = set(line.split(":", 1)[1].split())
                break
    except OSError:
        pass
    if platform.machine() in ("x86_64", "AMD64"):
        libm = "FMA variants" if {"fma", "avx2"} <= flags else "non-FMA variants"
    else:
        libm = platform.machine()
    return [
        f"numerics: libm takes its {libm}; numpy {_version('numpy')} dispatches to {targets}; "
        f"OPENBLAS_CORETYPE={os.environ.get('OPENBLAS_CORETYPE', '(its own choice)')}"
    ]


def info_lines() -> list[str]:
    """Every line ``simbridge info`` prints.

    Returns:
        The lines: simbridge's and Python's versions, how it is installed, each engine (MuJoCo's
        step loop with the MuJoCo it was built against), windows, numerics, the cache.
    """
    from simbridge import __version__
    from simbridge.cli.cache import fmt_size
    from simbridge.compare.run.cache import Cache
    from simbridge.registry import available_backends, backend_spec, unavailable_reason

    lines = [
        f"simbridge {__version__} (Python {platform.python_version()}, "
        f"{platform.system()} {platform.machine()})",
        install_line(),
        "engines:",
    ]
    for name in available_backends():
        spec = backend_spec(name)
        versions = ", ".join(
            f"{d} {_version(d)}" for d in spec.engine_dists if _version(d) is not None
        )
        missing = unavailable_reason(name)
        state = "installed" if missing is None else f"not usable: {missing}"
        line = f"  {name}: {versions or 'no engine'}; {state}"
        more = described(name) if missing is None else None
        if more:
            line += f"; {more}"
        lines.append(line)
    lines += display_lines()
    lines += _numerics()
    cache = Cache().info()
    made = "" if cache.dir.is_dir() else " (not made yet)"
    lines.append(f"cache: {cache.dir}{made}, {cache.entries} entries, {fmt_size(cache.size)}")
    return lines


def _info(args: argparse.Namespace) -> int:
    for line in info_lines():
        print(line)
    return 0
