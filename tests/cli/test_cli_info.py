"""``simbridge info``: what is installed and how it runs here, in the lines a bug report needs."""

from __future__ import annotations

import json
from importlib import metadata
from pathlib import Path

import simbridge
from simbridge.cli import main
from simbridge.cli.info import described, display_lines, install_line


def _info(capsys) -> list[str]:
    assert main(["info"]) == 0
    return capsys.readouterr().out.splitlines()


def test_every_engine_with_its_version_and_the_loop_in_use(capsys, monkeypatch, tmp_path):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    monkeypatch.delenv("SIMBRIDGE_MUJOCO_STEP", raising=False)
    lines = _info(capsys)
    assert lines[0].startswith("simbridge ") and "Python 3." in lines[0]
    assert f"  pybullet: pybullet {metadata.version('pybullet')}; installed" in lines
    mujoco = next(line for line in lines if line.startswith("  mujoco: "))
    assert mujoco.startswith(f"  mujoco: mujoco {metadata.version('mujoco')}; installed")
    assert mujoco.endswith(f"; {described('mujoco')}") and "; step loop: " in mujoco
    if "step loop: compiled" in mujoco:  # the MuJoCo it was built against, and the one running
        running = metadata.version("mujoco")
        assert mujoco.endswith(f"compiled (C), built against MuJoCo {running} (running {running})")
    assert lines[1] == install_line()
    assert any(line.startswith("  physx: ") for line in lines)  # installed or why not
    assert any(line.startswith("numerics: libm takes its ") for line in lines)
    # the cache: its folder, not made yet in a new home
    assert f"cache: {tmp_path / 'simbridge'} (not made yet), 0 entries, 0 B" in lines


def test_the_python_loop_is_said_with_why(capsys, monkeypatch):
    monkeypatch.setenv("SIMBRIDGE_MUJOCO_STEP", "python")
    mujoco = next(line for line in _info(capsys) if line.startswith("  mujoco: "))
    assert mujoco.endswith("step loop: Python, about 12x slower: SIMBRIDGE_MUJOCO_STEP=python")


def test_windows_say_what_is_missing():
    assert display_lines({})[0].startswith("windows: no DISPLAY: gui=True needs an X server")
    line = display_lines({"DISPLAY": ":4711"})[0]
    assert line == "windows: DISPLAY=:4711 (no socket for it in /tmp/.X11-unix)"
    assert display_lines({"DISPLAY": "remote:0"})[0] == "windows: DISPLAY=remote:0"
    assert display_lines({})[1].startswith("  physx's window: Vulkan drivers: ")


def test_the_install_is_said_editable_or_a_wheel_and_where_it_is_imported_from():
    line = install_line()
    where = Path(simbridge.__file__).resolve().parent
    assert line.endswith(f"; imported from {where}")
    direct = json.loads(metadata.distribution("simbridge").read_text("direct_url.json") or "{}")
    if direct.get("dir_info", {}).get("editable"):  # this checkout, installed with pip -e
        checkout = direct["url"].removeprefix("file://")
        assert line.startswith(f"install: editable, from the checkout {checkout};")
        assert where.is_relative_to(checkout)
    else:  # a wheel (tests/test_packaging.py runs `simbridge info` from one)
        assert line.startswith("install: a wheel")
    assert install_line("no-such-distribution").startswith(
        "install: none (no no-such-distribution distribution found); imported from "
    )
