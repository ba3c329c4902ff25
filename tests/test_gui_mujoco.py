"""tests/test_gui.py's window rows for MuJoCo, in a module of their own so that the two pytest
workers (``--dist loadfile``) share the window tests out (see test_gui.WINDOWED). The tests are
test_gui's own functions, run under this module's Xvfb."""

from __future__ import annotations

import pytest
import test_gui as gui
from test_gui import display  # noqa: F401 (the fixture: this module's own Xvfb)

pytestmark = gui.pytestmark


@pytest.mark.parametrize("backend", ["mujoco"])
def test_the_window_shows_the_robot(display, backend, tmp_path):  # noqa: F811
    gui.test_the_window_shows_the_robot(display, backend, tmp_path)


@pytest.mark.parametrize("backend", ["mujoco"])
def test_close_ends_the_process_cleanly_ten_runs_in_a_row(display, backend):  # noqa: F811
    gui.test_close_ends_the_process_cleanly_ten_runs_in_a_row(display, backend)


@pytest.mark.parametrize("backend", ["mujoco"])
def test_the_mujoco_reading_shows_the_ant_and_closes_cleanly(display, backend):  # noqa: F811
    gui.test_the_mujoco_reading_shows_the_ant_and_closes_cleanly(display, backend)
