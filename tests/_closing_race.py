"""A call waiting for a Sim's lock while the thread that holds it closes the Sim: the waiting
call gets SimClosedError once it has the lock (it went on into the closed engine, a raw
KeyError on both backends, measured). Each backend's own test file runs it with the lock its
inspect module reaches (the conformance suite speaks the public interface alone)."""

from __future__ import annotations

import threading
import time
from typing import Any

from simbridge.exceptions import SimClosedError


def check_waiting_call_refused_after_close(sim: Any, lock: Any) -> None:
    robot = sim.load_urdf("r2d2.urdf", base_position=(0, 0, 0.5))
    outcome: list[object] = []

    def reader() -> None:
        try:
            outcome.append(sim.base_state(robot))
        except BaseException as error:  # noqa: BLE001 - reported below
            outcome.append(error)

    lock.acquire()  # held here as a long call would hold it
    try:
        t = threading.Thread(target=reader)
        t.start()
        time.sleep(0.05)  # the reader is waiting for the lock
        assert outcome == []
        sim.close()  # the same thread: its own lock, taken again
    finally:
        lock.release()
    t.join(timeout=20)
    assert not t.is_alive()
    assert len(outcome) == 1 and isinstance(outcome[0], SimClosedError), outcome
