"""A call waiting for a Sim's lock while the thread that holds it closes the Sim: the waiting
call gets SimClosedError once it has the lock (it went on into the closed engine, a raw
KeyError on both backends, measured). Each backend's own test file runs it with the lock its
inspect module reaches (the conformance suite speaks the public interface alone).

The Sim is closed once the reader is seen waiting for the lock (its thread's stack is inside
``wait_for_lock``), and its SimClosedError must come from there: a reader that reached the Sim
only after the close would get the closed Sim's ordinary error, which says nothing of the race
(a fixed pause of 0.05 s assumed the reader was waiting by then, and never checked it)."""

from __future__ import annotations

import threading
import traceback
from typing import Any

from _threads import wait_until_waiting

from simbridge.exceptions import SimClosedError

WAIT = "wait_for_lock"  # backends/locking.py: where a call waits for another thread's


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
        wait_until_waiting(t, WAIT)
        assert outcome == []
        sim.close()  # the same thread: its own lock, taken again
    finally:
        lock.release()
    t.join(timeout=20)
    assert not t.is_alive()
    assert len(outcome) == 1 and isinstance(outcome[0], SimClosedError), outcome
    # raised where it waited, once it had the lock: the race, not the closed Sim's refusal
    where = [f.name for f in traceback.extract_tb(outcome[0].__traceback__)]
    assert where[-1] == WAIT, where
