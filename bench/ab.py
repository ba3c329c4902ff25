"""bench/calls.py before and after a change: two source trees' runs in turn, compared.

    python bench/ab.py BEFORE AFTER [--rounds 3] [-- calls.py options]

BEFORE and AFTER are simbridge source trees, each with its own virtual environment in
``.venv`` where it is installed (``pip install -e .``: the compiled step loop is built there).
Each round runs this tree's ``bench/calls.py`` (the same timing code for both) in BEFORE's
interpreter, then in AFTER's (``--stat min --repeats 5`` unless options are given after
``--``), and the table gives, per row
and per timed column, the least over the rounds of each tree's figure and AFTER / BEFORE. The
rounds alternate, so that load from other work on the machine falls on both trees alike;
compare the ratios, not the times across machines.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

# the timed columns of bench/calls.py's tables (a layer's figure: raw engine calls do not
# depend on the tree)
TIMED = ("PyBullet µs", "MuJoCo µs", "PhysX µs", "plain µs", "bound µs")


def tables(text: str) -> dict[tuple[str, str], float]:
    """(row, column) -> µs of every timed cell of bench/calls.py's markdown tables."""
    out: dict[tuple[str, str], float] = {}
    header: list[str] = []
    for line in text.splitlines():
        if not line.startswith("|"):
            header = []
            continue
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if not header:
            header = cells
            continue
        if set(cells[0]) <= {"-"}:
            continue
        for name, cell in zip(header[1:], cells[1:], strict=False):
            if name in TIMED:
                try:
                    out[(cells[0], name)] = float(cell.split()[0])
                except (ValueError, IndexError):
                    pass  # "-" or "<0.01"
    return out


def run(tree: Path, options: list[str]) -> dict[tuple[str, str], float]:
    """One run of bench/calls.py on the simbridge installed in ``tree``'s .venv."""
    python = tree / ".venv" / "bin" / "python"
    done = subprocess.run(
        [str(python), str(Path(__file__).resolve().parent / "calls.py"), *options],
        cwd=tree,
        capture_output=True,
        text=True,
    )
    if done.returncode:
        raise SystemExit(f"bench/calls.py failed in {tree}:\n{done.stderr[-2000:]}")
    return tables(done.stdout)


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    options = ["--stat", "min", "--repeats", "5"]
    if "--" in argv:
        cut = argv.index("--")
        argv, options = argv[:cut], argv[cut + 1 :]
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("before", type=Path)
    parser.add_argument("after", type=Path)
    parser.add_argument("--rounds", type=int, default=3, help="runs of each tree (default 3)")
    args = parser.parse_args(argv)
    best: dict[str, dict[tuple[str, str], float]] = {"before": {}, "after": {}}
    for k in range(max(1, args.rounds)):
        for which in ("before", "after"):
            for key, value in run(getattr(args, which), options).items():
                seen = best[which].get(key)
                best[which][key] = value if seen is None else min(seen, value)
            print(f"round {k + 1}: {which} done", file=sys.stderr, flush=True)
    print(f"# bench/calls.py {' '.join(options)}: least of {args.rounds} rounds per tree")
    print(f"# before: {args.before}  after: {args.after}")
    print()
    print("| row | column | before µs | after µs | after / before |")
    print("|------|------|------|------|------|")
    for key, before in best["before"].items():
        after = best["after"].get(key)
        if after is None:
            continue
        ratio = f"{after / before:.3f}" if before > 0 else "-"
        print(f"| {key[0]} | {key[1]} | {before:.2f} | {after:.2f} | {ratio} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
