"""What capturing the engine's output costs: an empty capture window, and PyBullet's URDF load
and DIRECT connect raw against the same call inside a window (raw figure, layer figure,
ratio), the two interleaved at random in one run so that a busy machine weighs on both alike.

    python bench/engine_output.py [--repeats N]
"""

from __future__ import annotations

import argparse
import random
import statistics
import time
from collections.abc import Callable

from simbridge.engine_output import captured
from simbridge.model.urdf import resolve_source
from simbridge.registry import load_backend


def _median_us(fn: Callable[[], object], n: int) -> float:
    times = []
    for _ in range(n):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times) * 1e6


def _side_by_side(
    raw: Callable[[], object], layer: Callable[[], object], n: int
) -> tuple[float, float]:
    """Medians in us of ``raw`` and ``layer``, n calls each, in a random interleaved order."""
    times: dict[int, list[float]] = {0: [], 1: []}
    order = [0, 1] * n
    random.shuffle(order)
    for which in order:
        fn = layer if which else raw
        t0 = time.perf_counter()
        fn()
        times[which].append(time.perf_counter() - t0)
    return statistics.median(times[0]) * 1e6, statistics.median(times[1]) * 1e6


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=200, help="calls of each kind")
    n = parser.parse_args().repeats
    load_backend("pybullet")  # registers PyBullet's classifier; imports pybullet quietly
    import pybullet as p

    urdf = str(resolve_source("r2d2.urdf").path)
    c = p.connect(p.DIRECT)

    def empty() -> None:
        with captured("pybullet"):
            pass

    def raw_load() -> None:
        p.resetSimulation(physicsClientId=c)
        p.loadURDF(urdf, physicsClientId=c)

    def layer_load() -> None:
        p.resetSimulation(physicsClientId=c)
        with captured("pybullet"):
            p.loadURDF(urdf, physicsClientId=c)

    def raw_connect() -> None:
        p.disconnect(physicsClientId=p.connect(p.DIRECT))

    def layer_connect() -> None:
        with captured("pybullet"):
            client = p.connect(p.DIRECT)
        p.disconnect(physicsClientId=client)

    rows = [("empty capture window", 0.0, _median_us(empty, 10 * n))]
    rows.append(("reset + loadURDF r2d2", *_side_by_side(raw_load, layer_load, n)))
    rows.append(("connect + disconnect (DIRECT)", *_side_by_side(raw_connect, layer_connect, n)))
    p.disconnect(physicsClientId=c)
    print("| case | raw (us) | in a capture window (us) | ratio |")
    print("|---|---|---|---|")
    for name, raw, layer in rows:
        if raw:
            print(f"| {name} | {raw:.0f} | {layer:.0f} | {layer / raw:.3f} |")
        else:
            print(f"| {name} | - | {layer:.1f} | - |")


if __name__ == "__main__":
    main()
