"""MuJoCo's passive viewer for ``Sim(gui=True)``: opened on a world, kept in step, closed."""

from __future__ import annotations

import os
import sys
from typing import Any

from simbridge.exceptions import DisplayError

__all__ = ["Viewer", "check_display"]


def check_display(backend: str) -> None:
    """DisplayError where no window can open (Linux without DISPLAY or WAYLAND_DISPLAY)."""
    if sys.platform.startswith("linux") and not (
        os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")
    ):
        raise DisplayError(backend, "neither DISPLAY nor WAYLAND_DISPLAY is set")


class Viewer:
    """A passive viewer window on one model and data (a new model needs a new window)."""

    def __init__(self, backend: str, m: Any, d: Any) -> None:
        try:
            import mujoco.viewer

            self._handle: Any = mujoco.viewer.launch_passive(m, d)
        except Exception as exc:  # noqa: BLE001 - any failure to open a window
            raise DisplayError(backend, f"mujoco.viewer.launch_passive failed: {exc}") from None

    def sync(self) -> None:
        """Show the current state (nothing once the user has closed the window)."""
        h = self._handle
        if h.is_running():
            h.sync()

    def close(self) -> None:
        self._handle.close()
