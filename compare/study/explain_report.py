"""``simbridge explain``'s report: :func:`explanation_lines` (the words of ``explain.md``) and
:func:`plot_explanation` (its figure)."""

from __future__ import annotations

from pathlib import Path

from ..analysis.verdict import Interval
from ..scenario import format_timestep
from .explain import EXPLAINS, PARTLY, Explanation, _pct

__all__ = ["explanation_lines", "plot_explanation"]


def explanation_lines(e: Explanation) -> list[str]:
    """report.md of an explain study."""
    lines = [
        f"# Explain: {e.scenario} on {', '.join(e.labels)}",
        "",
        f"Every run at dt = {format_timestep(e.timestep)} s"
        + (f", the first {e.duration:g} s" if e.duration else "")
        + f", with ensembles of {e.ensemble} runs per engine (compare's default is 16: smaller "
        f"here so that every candidate's rerun stays short); {e.wall_time:.0f} s in all.",
        "",
        "Each candidate moves one setting toward the other engine's behaviour and reruns the "
        "pair. The share of the gap removed is 1 - gap after / gap before, the gap being the "
        "median distance between the two engines' runs at the instant the pair's verdict was "
        "judged; its 95% interval is a bootstrap over the four ensembles. A candidate explains "
        f"the gap when it removes at least {EXPLAINS:.0%} (interval's low end at least "
        f"{PARTLY:.0%}).",
    ]
    for p in e.pairs:
        u = p.before.unit
        lines += [
            "",
            f"## {p.labels[0]} - {p.labels[1]}",
            "",
            f"Before: **{p.before.verdict}** ({p.before.reason}); gap at t = {p.instant:.3f} s: "
            f"{_iv(p.gap, u)}.",
            "",
            f"**{p.conclusion}**",
        ]
        if p.note:
            continue
        lines += [
            "",
            "### Candidates",
            "",
            "| setting | moved to | from | why |",
            "|---|---|---|---|",
        ]
        for r in p.ranked:
            c = r.candidate
            lines.append(f"| {c.name} | {c.describe(p.labels)} | {c.source} | {c.why} |")
        for key, why in p.not_tested:
            lines.append(f"| (departure: {key}) | not tested | departure applies | {why} |")
        for c, err in p.failed:
            lines.append(
                f"| {c.name} | {c.describe(p.labels)} | {c.source} | {c.why}; **the rerun "
                f"failed**: {err} |"
            )
        if p.not_checked:
            n = len(p.not_checked)
            lines += [
                "",
                f"Left out: {n} departure{'s' if n != 1 else ''} the engines list but that "
                f"{'are' if n != 1 else 'is'} not checked against this scenario (as the compare "
                f"report marks {'them' if n != 1 else 'it'}), not tested: "
                + ", ".join(p.not_checked)
                + ".",
            ]
        if p.ranked:
            lines += [
                "",
                "### Ranking",
                "",
                "| rank | setting | share of the gap removed [95%] | gap after [95%] | verdict "
                "after | explains | profiles run | wall |",
                "|---|---|---|---|---|---|---|---|",
            ]
            for i, r in enumerate(p.ranked, 1):
                lines.append(
                    f"| {i} | {r.candidate.name} | {_pct(r.share)} | {_iv(r.gap, u)} "
                    f"| {r.after.verdict} | {r.explains} | {' / '.join(r.profiles)} "
                    f"| {r.wall_time:.1f} s |"
                )
    return lines


def _iv(x: Interval, unit: str) -> str:
    from ..report.fmt import fmt_value

    if x.low is None or x.high is None:
        return fmt_value(x.value, unit)
    return f"{fmt_value(x.value, unit)} [{fmt_value(x.low, unit)}, {fmt_value(x.high, unit)}]"


def plot_explanation(e: Explanation, out: Path) -> list[str]:
    """Per pair with candidates: the share each removes (bars with intervals)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = []
    for p in e.pairs:
        if not p.ranked:
            continue
        fig, ax = plt.subplots(figsize=(7, 0.6 + 0.5 * len(p.ranked)))
        ys = list(range(len(p.ranked)))[::-1]
        vals = [100 * r.share.value for r in p.ranked]
        lo = [
            100 * (r.share.value - (r.share.low if r.share.low is not None else r.share.value))
            for r in p.ranked
        ]
        hi = [
            100 * ((r.share.high if r.share.high is not None else r.share.value) - r.share.value)
            for r in p.ranked
        ]
        ax.barh(ys, vals, xerr=[lo, hi], capsize=3, color="tab:blue")
        ax.set_yticks(ys, [r.candidate.name for r in p.ranked])
        ax.axvline(0, color="black", lw=0.8)
        ax.axvline(100 * EXPLAINS, color="grey", ls=":", lw=1)
        ax.set_xlabel("share of the gap removed (%), 95% interval")
        ax.set_title(f"{p.labels[0]} - {p.labels[1]}", fontsize=10)
        fig.tight_layout()
        stem = "".join(ch if ch.isalnum() else "_" for ch in f"{p.labels[0]}-{p.labels[1]}")
        name = f"explain_{stem}.png"
        fig.savefig(out / name, dpi=110)
        plt.close(fig)
        names.append(name)
    return names
