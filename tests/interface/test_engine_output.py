"""What the engines write from C goes to the simbridge logger; nothing else is held or lost.

capfd captures at the file-descriptor level, where PyBullet writes with printf.
"""

from __future__ import annotations

import logging
import os
import signal
import subprocess
import sys
import threading

import pytest
from _threads import wait_until_waiting

import simbridge
from simbridge.engine_output import captured
from simbridge.registry import load_backend

# a real URDF on which PyBullet prints b3Warning lines ("No inertial data for link") on load
WARNING_URDF = "quadruped/spirit40newer.urdf"


@pytest.fixture(autouse=True)
def _pybullet_classifier() -> None:
    load_backend("pybullet")  # registers PyBullet's classifier


def test_a_warning_emitting_load_logs_and_prints_nothing(capfd, caplog):
    caplog.set_level(logging.DEBUG, logger="simbridge")
    with simbridge.Sim("pybullet") as sim:
        body = sim.load_urdf(WARNING_URDF)
        assert sim.num_joints(body) == 20
    assert capfd.readouterr() == ("", "")
    engine = [r for r in caplog.records if r.name == "simbridge.pybullet"]
    # PyBullet's own lines are kept, at DEBUG: the URDF reader says the same on every backend,
    # with the file and the line (one warning per link, not two)
    assert len(engine) == 4 and all(r.levelno == logging.DEBUG for r in engine)
    text = engine[0].getMessage()
    assert "(loading " in text and text.endswith(
        "No inertial data for link, using mass=1, localinertiadiagonal = 1,1,1, identity local "
        "inertial frame: FR_upper_shoulder"
    )
    warnings = [r for r in caplog.records if r.levelno >= logging.WARNING]
    assert [r.name for r in warnings] == ["simbridge.model.urdf"] * 4
    assert "spirit40newer.urdf:85: link 'FR_upper_shoulder' has no <inertial>" in (
        warnings[0].getMessage()
    )


def test_a_quiet_load_logs_nothing(capfd, caplog):
    caplog.set_level(logging.DEBUG, logger="simbridge")
    with simbridge.Sim("pybullet") as sim:
        sim.load_urdf("r2d2.urdf")
    assert capfd.readouterr() == ("", "")
    assert not [r for r in caplog.records if r.name.startswith("simbridge")]


def test_the_banner_is_a_debug_record_in_a_fresh_process():
    code = (
        "import logging, sys\n"
        "logging.basicConfig(level=logging.DEBUG, stream=sys.stdout, format='%(levelname)s "
        "%(name)s %(message)s')\n"
        "import simbridge\n"
        "simbridge.Sim('pybullet').close()\n"
    )
    child = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=120
    )
    assert child.returncode == 0, child.stderr
    assert child.stderr == ""
    assert child.stdout.startswith(
        "DEBUG simbridge.pybullet pybullet (importing): pybullet build time: "
    )
    assert child.stdout.count("\n") == 1


@pytest.mark.parametrize(
    "module",
    [
        "pybullet.backend",
        "pybullet.reads",
        "pybullet.commands",
        "pybullet.contacts",
        "pybullet.world",
        "pybullet.records",
        "pybullet.scene",
        "pybullet.inspect",
    ],
)
def test_importing_a_backend_module_directly_prints_nothing(module):
    """Each PyBullet backend module takes pybullet from the one import that captures its banner
    (a test or a tool importing a module directly printed it)."""
    child = subprocess.run(
        [sys.executable, "-c", f"import simbridge.backends.{module}"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert child.returncode == 0, child.stderr
    assert (child.stdout, child.stderr) == ("", "")


def test_no_handler_means_nothing_on_stderr(capfd):
    """A library user who configured no logging sees no engine warning (no last-resort
    handler): the simbridge logger has a NullHandler."""
    with simbridge.Sim("pybullet") as sim:
        sim.load_urdf(WARNING_URDF)
    assert capfd.readouterr() == ("", "")


def test_text_that_is_not_the_engines_goes_back_where_it_was_going(capfd, caplog):
    caplog.set_level(logging.DEBUG, logger="simbridge")
    with captured("pybullet", "a test"):
        print("a print of the user's", flush=True)
        os.write(1, b"b3Warning[file.cpp,1]:\nfrom the engine\n")
        os.write(2, b"to stderr\npybullet build time: today\n")
    out, err = capfd.readouterr()
    assert out == "a print of the user's\n"
    assert err == "to stderr\n"
    records = [(r.levelno, r.getMessage()) for r in caplog.records]
    assert records == [
        (logging.WARNING, "pybullet (a test): from the engine"),
        (logging.DEBUG, "pybullet (a test): pybullet build time: today"),
    ]


def test_without_a_classifier_nothing_is_claimed(capfd, caplog):
    caplog.set_level(logging.DEBUG, logger="simbridge")
    with captured("no-such-engine"):
        os.write(1, b"b3Warning[file.cpp,1]:\nnot claimed\n")
    assert capfd.readouterr().out == "b3Warning[file.cpp,1]:\nnot claimed\n"
    assert not caplog.records


def test_a_window_inside_another_joins_it(capfd, caplog):
    caplog.set_level(logging.DEBUG, logger="simbridge")
    with captured("pybullet", "outer"):
        with captured("no-such-engine", "inner"):
            os.write(1, b"b3Error[f,2]:\ninner line\n")
        os.write(1, b"after\n")
    assert capfd.readouterr().out == "after\n"
    assert [(r.levelno, r.getMessage()) for r in caplog.records] == [
        (logging.ERROR, "pybullet (outer): inner line")
    ]


def test_more_than_a_pipe_holds_does_not_block(capfd):
    big = b"x" * 999 + b"\n"
    with captured("pybullet"):
        for _ in range(1000):  # 1 MB, 16 pipe buffers
            os.write(1, big)
    assert capfd.readouterr().out == big.decode() * 1000


def test_the_descriptors_come_back_when_the_body_raises(capfd, caplog):
    caplog.set_level(logging.DEBUG, logger="simbridge")
    with pytest.raises(KeyError), captured("pybullet", "failing"):
        os.write(1, b"b3Error[f,1]:\nbefore the exception\n")
        raise KeyError("x")
    os.write(1, b"after\n")
    assert capfd.readouterr().out == "after\n"
    assert [r.getMessage() for r in caplog.records] == ["pybullet (failing): before the exception"]


def test_another_threads_output_is_held_back_not_dropped_and_windows_take_turns(capfd):
    opened, written, second_in = threading.Event(), threading.Event(), threading.Event()
    seen: list[bool] = []

    def first() -> None:
        with captured("pybullet"):
            opened.set()
            written.wait(10)
            # the second window waits for this one: once its thread is seen at the window's
            # lock (a pause of 0.05 s let a late thread pass without having tried), it is not in
            wait_until_waiting(b, "captured", "with _lock")
            seen.append(second_in.is_set())

    def second() -> None:
        with captured("pybullet"):
            second_in.set()

    a = threading.Thread(target=first)
    b = threading.Thread(target=second)
    a.start()
    assert opened.wait(10)
    os.write(1, b"printed by another thread meanwhile\n")  # lands in the open window
    b.start()
    written.set()
    a.join(10)
    b.join(10)
    assert seen == [False] and second_in.is_set()
    assert capfd.readouterr().out == "printed by another thread meanwhile\n"


def test_the_helper_imports_no_engine():
    code = (
        "import sys, simbridge.engine_output\n"
        "print(sorted(m for m in ('pybullet', 'mujoco') if m in sys.modules))\n"
    )
    child = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert child.stdout == "[]\n", child.stderr


@pytest.mark.skipif(not hasattr(os, "fork"), reason="no fork here")
def test_a_fork_while_another_thread_holds_a_window(capfd):
    opened, done = threading.Event(), threading.Event()

    def hold() -> None:
        with captured("pybullet"):
            opened.set()
            done.wait(10)

    holder = threading.Thread(target=hold)
    holder.start()
    assert opened.wait(10)
    pid = os.fork()
    if pid == 0:  # the child: the holder thread is not here
        try:
            signal.alarm(10)  # a window that waited for the parent's thread would hang
            with captured("pybullet"):
                os.write(1, b"b3Warning[f,1]:\nin the child\n")
            os.write(1, b"from the child\n")
        finally:
            os._exit(0)
    _, status = os.waitpid(pid, 0)
    done.set()
    holder.join(10)
    assert status == 0
    assert capfd.readouterr().out == "from the child\n"
