"""The one-step model error of two engines and their floors (compare/resync.py), per scenario.

    python bench/resync.py                          # every shipped scenario, PyBullet and MuJoCo
    python bench/resync.py r2d2 r2d2-gentle pendulum --every 5

Each engine runs the scenario; every ``--every`` steps (default about 150 points per run) its
state, taken after that step's commands and before the step, is set into a Sim of the other
engine and into a second Sim of its own (the floor), each steps once and is compared with the
source's next recorded state. One markdown row per scenario and direction: the largest error in
the scenario's headline quantity (with its phase and time), the median, the floor's largest and
median, the largest joint velocity error and its floor, and where the model error is born.
Accuracy figures, not timings: the result does not depend on the machine's load.
"""

from __future__ import annotations

from collections.abc import Sequence

from simbridge.compare.report.fmt import fmt_time, fmt_value
from simbridge.compare.report.summary_json import resync_dict
from simbridge.compare.run.resync import resync
from simbridge.compare.scenario import list_scenarios, load_scenario


def _fmt(v: float | None, unit: str) -> str:
    return "n/a" if v is None else fmt_value(v, unit)


def main(argv: Sequence[str] | None = None) -> None:
    import argparse

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("scenarios", nargs="*", help="shipped names or TOML files (all)")
    parser.add_argument("--every", type=int, default=None, help="steps between resyncs")
    parser.add_argument("--backends", nargs=2, default=["pybullet", "mujoco"])
    args = parser.parse_args(argv)
    scenarios = [load_scenario(s) for s in args.scenarios] or list_scenarios()
    print(
        "| scenario | every | direction | largest (phase, t) | median | floor: largest, median "
        "| joint velocity: largest, floor | born |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for sc in scenarios:
        r = resync(sc, args.backends, every=args.every)
        s = resync_dict(r)
        unit = s["unit"]
        for d in s["directions"]:
            big = d["max"]
            jv = d["parts"]["joint_velocities"]
            born = s["born"]
            print(
                f"| {sc.name} | {s['every']} | {d['source']} -> {d['target']} "
                f"| {_fmt(big['value'], unit)} ({big['phase']}, {fmt_time(big['time'])}) "
                f"| {_fmt(d['median'], unit)} "
                f"| {_fmt(d['floor_max']['value'], unit)}, {_fmt(d['floor_median'], unit)} "
                f"| {_fmt(jv['max'], 'rad/s')}, {_fmt(jv['floor_max'], 'rad/s')} "
                f"| {'-' if born is None else born['phase'] + ' ' + fmt_time(born['time'])} |"
            )


if __name__ == "__main__":
    main()
