"""SIGTERM (``kill``, ``timeout``) stops `simbridge compare` the way Ctrl-C does: its pool's
workers are stopped and reaped and its semaphores released (the multiprocessing resource
tracker reports no 'leaked semaphore objects'), the report folder it made is removed."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from _held import held_scenario, wait_for_holding

from simbridge.terminate import Terminated, sigterm_raises


def test_sigterm_raises_terminated_within_the_block_only():
    with sigterm_raises(), pytest.raises(Terminated):
        os.kill(os.getpid(), signal.SIGTERM)
        time.sleep(5)  # the handler raises before this ends
    assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL
    assert isinstance(Terminated(), KeyboardInterrupt)  # handled where Ctrl-C is


def test_a_handler_of_the_caller_is_kept():
    def mine(signum, frame):
        raise RuntimeError("the caller's")

    previous = signal.signal(signal.SIGTERM, mine)
    try:
        with sigterm_raises():
            assert signal.getsignal(signal.SIGTERM) is mine
    finally:
        signal.signal(signal.SIGTERM, previous)


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads /proc (Linux)")
def test_sigterm_stops_the_pool_and_leaks_nothing(tmp_path):
    # signalled once two workers hold a run (tests/compare/_held.py): the runs cannot end
    # first, on any machine (the shipped pendulum's 40-run ensemble often did on a fast one)
    scenario, ready = held_scenario(tmp_path)
    out = tmp_path / "out"
    proc = subprocess.Popen(
        [sys.executable, "-m", "simbridge", "compare", str(scenario), "--backends", "pybullet",
         "pybullet", "--ensemble", "40", "--workers", "2", "--no-plots", "--no-replay",
         "--cache", str(tmp_path / "cache"), "--out", str(out)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        wait_for_holding(proc, ready, 2)
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert "leaked" not in err, err
    assert proc.returncode == 128 + signal.SIGTERM, err
    assert "terminated" in err
    assert not out.exists()  # nothing was written: the folder the run made is gone
