"""The verdict in words (:func:`verdict_lines`), from ``summary.json``'s ``verdict`` and
``ensemble`` alone, and the reasons a verdict is marginal (:func:`marginal_words`)."""

from __future__ import annotations

from typing import Any, NamedTuple

from ..analysis.verdict import ALPHA, MARGINAL, OWN_ERROR_REASONS, Marginal
from ..run.ensemble import FLOAT_SPACINGS
from .fmt import fmt_apart, fmt_threshold, fmt_time, fmt_value

__all__ = [
    "verdict_lines",
    "marginal_words",
    "verdict_word",
    "pair_words",
    "interval_cell",
    "time_step_share",
    "within_words",
    "against_words",
    "marginal_note",
    "own_error_words",
    "one_run",
    "spread_ratio",
]


def marginal_words(m: Marginal) -> str:
    """``the gap is 1.1x mujoco's own time-step error``."""
    if m.what == "tolerance":
        return f"the largest gap is {m.ratio:.3g}x the tolerance"
    if m.what == "spread":
        return f"the gap is {m.ratio:.3g}x {m.label}'s spread"
    return f"the gap is {m.ratio:.3g}x {m.label}'s own time-step error"


def against_words(ratio: float, figure: str) -> str:
    """The gap against one figure in words its ratio makes true: ``within pybullet's own
    time-step error`` at most 1x, else the ratio itself, ``1.13x pybullet's own time-step
    error``."""
    return f"within {figure}" if ratio <= 1.0 else f"{_x(ratio)} {figure}"


def own_error_words(v: dict[str, Any], *, sizes: bool = True) -> str:
    """An ``unresolved`` verdict's engines whose own time-step error covers the gap, each as
    its ratio makes true: ``within mujoco's own time-step error (24.3 cm between dt and
    dt/2)``, ``1.13x pybullet's own time-step error (2.0 cm between dt and dt/2) and 1.08x
    physx's (2.1 cm between dt and dt/2)``; without ``sizes``, the words alone."""
    unit = v["unit"]
    figs = v["engine_figures"]
    parts = []
    for k, lab in enumerate(v["engines"]):
        r = figs[lab]["gap_over_own_error"]
        noun = f"{lab}'s own time-step error" if k == 0 else f"{lab}'s"
        words = against_words(r, noun)
        if sizes:
            words += f" ({fmt_value(figs[lab]['own_error'], unit)} between dt and dt/2)"
        parts.append(words)
    return " and ".join(parts)


def marginal_note(v: dict[str, Any]) -> str:
    """Why a verdict is marginal and what that means: ``marginal: the gap is 1.1x pybullet's
    spread; a ratio between 0.5x and 2x is near 1`` (empty where it is not)."""
    if not v["marginal"]:
        return ""
    lo, hi = v.get("marginal_range") or MARGINAL
    reasons = "; ".join(v["marginal_reasons"])
    return f"marginal: {reasons}; a ratio between {lo:g}x and {hi:g}x is near 1"


def near_words(v: dict[str, Any]) -> str:
    """What a ratio above 1 that still covers the gap means: ``not clearly larger (a ratio
    between 0.5x and 2x is near 1)``."""
    lo, hi = v.get("marginal_range") or MARGINAL
    return f"not clearly larger (a ratio between {lo:g}x and {hi:g}x is near 1)"


def time_step_share(v: dict[str, Any]) -> str | None:
    """Where the verdict is ``chaotic`` but an engine's own time-step error covers the gap (at
    most 2x it) at more instants than the chaotic engines' spread does: ``the gap is at most
    2x mujoco's own time-step error at 980 of 981 instants (at most 2x pybullet's spread at
    210)``; else None.

    Chaos is named first (at the judged instant the chaotic engine's own runs are as far apart
    as the engines, so its single runs cannot show an engine difference at this time step);
    this says which share of the run the time step covers, that the headline not read as if
    chaos were the whole story."""
    within = (v.get("instants") or {}).get("within")
    if v["verdict"] != "chaotic" or not within:
        return None
    chaos = max(within[lab]["spread"] for lab in v["engines"])
    own = max(within, key=lambda lab: within[lab]["own_error"])
    n = within[own]["own_error"]
    if n <= chaos:
        return None
    spread = f"{v['engines'][0]}'s spread" if len(v["engines"]) == 1 else "a spread"
    hi = f"{(v.get('marginal_range') or MARGINAL)[1]:g}x"
    return (
        f"the gap is at most {hi} {own}'s own time-step error at {n} of "
        f"{v['instants']['total']} instants (at most {hi} {spread} at {chaos})"
    )


def within_words(v: dict[str, Any]) -> str | None:
    """``Counted alone (an instant may count for both, and for both engines): the gap is at
    most 2x pybullet's spread at 210 instants and 2x its own time-step error at 259; at most
    2x mujoco's spread at 0 and 2x its own time-step error at 980.``; None without the counts,
    or where the gap stays below the tolerance all along."""
    within = (v.get("instants") or {}).get("within")
    if not within or v["instants"]["agree"] == v["instants"]["total"]:
        return None
    hi = f"{(v.get('marginal_range') or MARGINAL)[1]:g}x"
    each = [
        f"at most {hi} {lab}'s spread at {w['spread']}"
        + (" instants" if k == 0 else "")
        + f" and {hi} its own time-step error at {w['own_error']}"
        for k, (lab, w) in enumerate(within.items())
    ]
    return (
        "Counted alone (an instant may count for both, and for both engines): the gap is "
        + "; ".join(each)
        + "."
    )


def _iv(x: dict[str, Any], unit: str, *, inner: bool = False) -> str:
    """``7.2 cm (95% interval 7.1 cm to 7.3 cm)`` (``inner``: ``7.2 cm, 95% interval ...``, for
    use inside parentheses); the value alone without an interval."""
    v = fmt_value(x["value"], unit)
    if x.get("low") is None:
        return v
    lo, hi = fmt_value(x["low"], unit), fmt_value(x["high"], unit)
    if x["low"] == x["high"]:
        return v
    if len({lo, v, hi}) < 3:  # too close for the report's rounding: more digits, same units
        v, lo, hi = fmt_apart([x["value"], x["low"], x["high"]], unit)
    return f"{v}, 95% interval {lo} to {hi}" if inner else f"{v} (95% interval {lo} to {hi})"


def verdict_word(v: dict[str, Any]) -> str:
    """The verdict as every writer names it: ``agree``, ``differ``, ``unresolved``,
    ``chaotic (pybullet)``, ``agree (marginal)``, ``chaotic (mujoco; marginal)``."""
    notes = []
    if v["verdict"] == "chaotic" and v["engines"]:
        notes.append(" and ".join(v["engines"]))
    if v["marginal"]:
        notes.append("marginal")
    return v["verdict"] + (f" ({'; '.join(notes)})" if notes else "")


def pair_words(pair: dict[str, Any], *, loud: bool = False) -> str:
    """One pair of ``summary.json``'s ``pairs`` in one line, the same figure for every pair:
    ``pybullet and mujoco: chaotic (pybullet), a median 4.09 m (95% interval 3.50 m to 4.60 m)
    apart at the end; p = 0.03`` (``loud``: the verdict in capitals, for the terminal). Without
    an ensemble verdict, the nominal runs' gap, named as such."""
    a, b = pair["labels"]
    v = pair["verdict"]
    h = pair["headline"]
    if not v:
        return (
            f"{a} and {b}: not judged (no ensemble); the nominal runs end "
            f"{fmt_value(h['final'], h['unit'])} apart"
        )
    unit = v["unit"]
    word = verdict_word(v)
    if v["marginal"]:  # what marginal means, where it is said
        word = word[: word.rindex("marginal")] + marginal_note(v) + ")"
    if loud:
        word = v["verdict"].upper() + word[len(v["verdict"]) :]
    t = v["judged_at"]
    when = "at the end" if t["why"] == "end" else f"at t = {fmt_time(t['time'])}"
    if one_run(v):  # one gap, no median of it
        line = f"{a} and {b}: {word}, the gap {_iv(v['gap'], unit)} {when}"
    else:
        line = f"{a} and {b}: {word}, a median {_iv(v['gap'], unit)} apart {when}"
    if v["test"] is not None:
        line += f"; {_p(v['test'])}"
    if v["verdict"] == "unresolved":
        reason = {
            "single run": "one run per engine",
            "not separated": "the runs are not told apart",
        }.get(v["reason"], v["reason"])
        if v["reason"] in OWN_ERROR_REASONS:
            reason = own_error_words(v, sizes=False)
        line += f" ({reason})"
    share = time_step_share(v)
    if share:
        line += f"; {share}"
    return line


def interval_cell(x: dict[str, Any], unit: str) -> str:
    """``7.2 cm [7.1 cm, 7.3 cm]`` for a table, rounded as :func:`_iv` rounds (in the report's
    units, with more digits where its rounding would make different ones alike); the value alone
    without an interval."""
    v = fmt_value(x["value"], unit)
    if x.get("low") is None:
        return v
    lo, hi = fmt_value(x["low"], unit), fmt_value(x["high"], unit)
    if len({lo, v, hi}) < 3 and x["low"] != x["high"]:
        v, lo, hi = fmt_apart([x["value"], x["low"], x["high"]], unit)
    return f"{v} [{lo}, {hi}]"


def one_run(v: dict[str, Any]) -> bool:
    """Whether a pair's verdict rests on one run per engine (``--ensemble 1``): no spread, no
    median, no offsets."""
    return any(f["size"] < 2 for f in v["engine_figures"].values())


def spread_ratio(f: dict[str, Any], floor: float) -> bool:
    """Whether a ratio of the gap to this engine's spread means anything: the engine ran more
    than once and its spread is above the precision floor (else there is no denominator)."""
    return f["size"] >= 2 and f["spread"]["value"] > floor


def _median(v: dict[str, Any]) -> str:
    """``a median `` over every pair of runs; nothing with one run per engine (one gap)."""
    return "" if one_run(v) else "a median "


def _x(r: float) -> str:
    """A ratio: ``1.04x``, ``33x``, ``670x``, ``3.1e7x``."""
    if r < 10:
        return f"{r:.3g}x"
    if r < 10_000:
        return f"{r:.3g}x" if r < 100 else f"{round(r, -1):.0f}x"
    return f"{r:.1e}x".replace("e+0", "e").replace("e+", "e")


def _p(test: dict[str, Any]) -> str:
    """``p = 0.029``; ``p < 0.001`` from random splits below that (their p-value cannot go
    under 1 / (splits + 1): it bounds the true one)."""
    p = test["p_value"]
    if not test["exact"] and p < 0.001:
        return "p < 0.001"
    return f"p = {p:.2g}"


def _perturbation(ensemble: dict[str, Any] | None, label: str | None = None) -> str:
    """``runs started <m> m / <rad> rad apart``: the requested sizes, or engine ``label``'s
    where its own differ (a float32 engine's, :func:`~simbridge.compare.run.ensemble.
    engine_perturbation`)."""
    if not ensemble:
        return "runs"
    pert = ensemble["perturbation"]
    own = ensemble.get("engines", {}).get(label, {}).get("perturbation") if label else None
    if own is not None and (own["position"], own["orientation"]) != (
        pert["position"],
        pert["orientation"],
    ):
        return f"runs started {own['position']:.3g} m / {own['orientation']:.3g} rad apart"
    return f"runs started {pert['position']:g} m / {pert['orientation']:g} rad apart"


def perturbation_words(ensemble: dict[str, Any] | None) -> str | None:
    """A sentence naming each engine whose perturbation was raised above the requested one and
    the size it got; None when every engine got the requested one."""
    if not ensemble or ensemble.get("size", 1) < 2:
        return None  # one run each: nothing was moved
    req = ensemble["perturbation"]
    raised = [
        f"{label} ({e['perturbation']['state_dtype']}) {e['perturbation']['position']:.3g} m "
        f"and {e['perturbation']['orientation']:.3g} rad"
        for label, e in (ensemble.get("engines") or {}).items()
        if "perturbation" in e
        and (
            e["perturbation"]["position"] != req["position"]
            or e["perturbation"]["orientation"] != req["orientation"]
        )
    ]
    if not raised:
        return None
    return (
        "An engine keeping its state in float32 cannot represent offsets that small at this "
        f"scenario's spawn pose: its runs were moved and turned by at least {FLOAT_SPACINGS} "
        "spacings of its type (at the largest spawn coordinate; at 1 for the orientation), in "
        "the same random directions: " + "; ".join(raised) + "."
    )


def verdict_lines(summary: dict[str, Any]) -> list[str]:
    """The verdict in words, from ``summary.json``'s ``verdict`` and ``ensemble`` alone.

    Args:
        summary: ``summary.json``'s dict, with a ``verdict``.

    Returns:
        The verdict's paragraphs (its word in bold first), then, unless the engines agree, the
        predictability horizons.
    """
    v = summary["verdict"]
    w = _VerdictWords.of(v, summary.get("ensemble"))
    write = {"agree": _agree_lines, "chaotic": _chaotic_lines, "differ": _differ_lines}
    lines = write.get(v["verdict"], _unresolved_lines)(v, w)
    lines += _horizon_lines(v, w.unit) if v["verdict"] != "agree" else []
    return lines


class _VerdictWords(NamedTuple):
    """What every verdict's words share, from ``summary.json``'s ``verdict`` and ``ensemble``."""

    ens: dict[str, Any] | None
    """``summary.json``'s ``ensemble``."""
    unit: str
    """The judged quantity's unit."""
    a: str
    """The first engine's label."""
    b: str
    """The second engine's label."""
    n: int
    """The first engine's number of runs."""
    started: str
    """How the runs were started (:func:`_perturbation`)."""
    when: str
    """``end``, or ``are, at t = 1.200 s,`` where the judged instant is not the end."""
    marg: str
    """`` (marginal: ...)`` where the verdict is marginal, else empty."""

    @classmethod
    def of(cls, v: dict[str, Any], ens: dict[str, Any] | None) -> _VerdictWords:
        """The words of the verdict ``v`` with the ensemble ``ens``."""
        a, b = v["labels"]
        at_end = v["judged_at"]["why"] == "end"
        return cls(
            ens=ens,
            unit=v["unit"],
            a=a,
            b=b,
            n=v["engine_figures"][a]["size"],
            started=_perturbation(ens),
            when="end" if at_end else f"are, at t = {fmt_time(v['judged_at']['time'])},",
            marg=f" ({marginal_note(v)})" if v["marginal"] else "",
        )


def _agree_lines(v: dict[str, Any], w: _VerdictWords) -> list[str]:
    """``agree``: the gap stays below the tolerance; each engine's spread."""
    figs = v["engine_figures"]
    unit = w.unit
    mg = v["max_gap"]
    spreads = " and ".join(f"{fmt_value(f['spread_max'], unit)} ({lab})" for lab, f in figs.items())
    return [
        f"**{w.a} and {w.b} agree on this scenario**{w.marg}: the gap between them stays below "
        f"{fmt_threshold(v['tolerance'], unit)} all along (largest {fmt_value(mg['value'], unit)}, "
        f"at t = {fmt_time(mg['time'])})."
        + (f" Each engine's {w.n} {w.started} spread by at most {spreads}." if w.n > 1 else "")
    ]


def _chaotic_lines(v: dict[str, Any], w: _VerdictWords) -> list[str]:
    """``chaotic``: how far the chaotic engine's own runs spread, then the gap against that
    spread (and against the own time-step error where it is near), then the test."""
    figs = v["engine_figures"]
    names = v["engines"]
    who = " and ".join(names)
    first = figs[names[0]]
    others = [lab for lab in (w.a, w.b) if lab not in names]
    ratio = " and ".join(f"{_x(figs[lab]['gap_over_spread'])} {lab}'s" for lab in names)
    near = ""
    if others:
        near = (
            f"; {others[0]}'s runs {w.when} a median "
            f"{fmt_value(first['other_to_nearest'], w.unit)} from the nearest {names[0]} run"
        )
    gap = (
        f"The two engines' runs {w.when} {_median(v)}{_iv(v['gap'], w.unit)} apart, {ratio} own "
        f"spread{near}: at this scale {who}'s outcome is not predictable, and the gap says "
        "nothing about the engines' physics." + _chaotic_own_error_words(v, w)
    )
    return [_chaotic_spread_words(v, w), gap + _chaotic_test_words(v)]


def _chaotic_spread_words(v: dict[str, Any], w: _VerdictWords) -> str:
    """The chaotic engine's runs, how far apart they end; the other engine's, how close."""
    figs = v["engine_figures"]
    names = v["engines"]
    first = figs[names[0]]
    verb = "is" if len(names) == 1 else "are"
    others = [lab for lab in (w.a, w.b) if lab not in names]
    words = (
        f"**{' and '.join(names)} {verb} chaotic on this scenario**{w.marg}: {first['size']} "
        f"{_perturbation(w.ens, names[0])} "
        f"{w.when} up to {fmt_value(first['largest_pair'], w.unit)} apart (spread "
        f"{_iv(first['spread'], w.unit, inner=True)})"
    )
    if others:
        o = figs[others[0]]
        words += (
            f"; {others[0]}'s {o['size']} runs {w.when} within "
            f"{fmt_value(o['largest_pair'], w.unit)} of each other"
        )
    return words + "."


def _chaotic_own_error_words(v: dict[str, Any], w: _VerdictWords) -> str:
    """Where the gap is also near an engine's own time-step error: that, and how much of the
    run the time step explains; else empty."""
    figs = v["engine_figures"]
    also = [lab for lab in (w.a, w.b) if figs[lab]["gap_over_own_error"] <= v["marginal_range"][1]]
    words = ""
    if also:
        words = (
            " The gap is also "
            + " and ".join(
                against_words(figs[lab]["gap_over_own_error"], f"{lab}'s own time-step error")
                + f" ({fmt_value(figs[lab]['own_error'], w.unit)} between dt and dt/2)"
                for lab in also
            )
            + (
                ""
                if all(figs[lab]["gap_over_own_error"] <= 1.0 for lab in also)
                else f", {near_words(v)}"
            )
            + "."
        )
    share = time_step_share(v)
    if share:
        words += (
            f" Chaos is named first: at this time step {' and '.join(v['engines'])}'s own runs "
            f"{w.when} as far apart as the two engines, so no single run here can show an engine "
            f"difference. But over the run {share}: for most of the run the gap is of the size of "
            "what halving the time step changes, not of chaos; a smaller --timestep tells whether "
            "it closes."
        )
    return words


def _chaotic_test_words(v: dict[str, Any]) -> str:
    """The permutation test's result in parentheses, where it ran; else empty."""
    t = v["test"]
    if t is None:
        return ""
    told = "tells" if t["p_value"] < ALPHA else "does not tell"
    return (
        f" (A permutation test on the energy distance {told} the two sets of runs apart, "
        f"{_p(t)}: "
        + (
            f"they are distributed differently, but within the spread of {v['engines'][0]}'s own "
            "runs.)"
            if t["p_value"] < ALPHA
            else "one engine's runs could be the other's.)"
        )
    )


def _differ_lines(v: dict[str, Any], w: _VerdictWords) -> list[str]:
    """``differ``: the gap against each engine's spread and time-step error, and the test that
    separates the runs."""
    unit = w.unit
    parts = "; ".join(
        f"{_x(f['gap_over_spread'])} {lab}'s own spread "
        f"({fmt_value(f['spread']['value'], unit)}) and {_x(f['gap_over_own_error'])} its "
        "time-step error"
        for lab, f in v["engine_figures"].items()
    )
    return [
        f"**{w.a} and {w.b} differ on this scenario**{w.marg}: their runs {w.when} {_median(v)}"
        f"{_iv(v['gap'], unit)} apart; that is {parts}.",
        f"A permutation test on the energy distance separates the two sets of {w.n} "
        f"{w.started} ({_p(v['test'])}): the gap is the engines', not chaos or the "
        "time step.",
    ]


def _unresolved_lines(v: dict[str, Any], w: _VerdictWords) -> list[str]:
    """``unresolved``: the gap, and why it cannot be judged (the time step, one run, or a test
    that does not separate the runs) with what to rerun."""
    reason = v["reason"]
    if reason in OWN_ERROR_REASONS:
        near = "" if reason == OWN_ERROR_REASONS[0] else f", {near_words(v)}"
        why = (
            f"which is {own_error_words(v)}{near}: at this time step the "
            "comparison cannot tell the engines apart; rerun with a smaller --timestep"
        )
    elif reason == "single run":
        why = (
            "and with one run per engine chaos cannot be told from an engine difference; "
            "rerun with --ensemble 8 or more"
        )
    else:
        why = (
            f"but the permutation test does not separate the two sets of {w.n} {w.started} "
            f"({_p(v['test'])}); a larger --ensemble may"
        )
    return [
        f"**Unresolved**{w.marg}: the engines' runs {w.when} {_median(v)}"
        f"{_iv(v['gap'], w.unit)} apart, {why}."
    ]


def _horizon_lines(v: dict[str, Any], unit: str) -> list[str]:
    """When each engine's runs first spread past each threshold, in one sentence (empty when no
    engine ran more than once)."""
    parts = []
    for lab, f in v["engine_figures"].items():
        if f["size"] < 2:
            continue
        hs = f["horizons"]
        reached = [h for h in hs if h["time"] is not None]
        if not reached:
            parts.append(f"{lab}'s spread never reaches {fmt_threshold(hs[0]['threshold'], unit)}")
        else:
            parts.append(
                f"{lab}'s reaches "
                + ", ".join(
                    f"{fmt_threshold(h['threshold'], unit)} at t = {fmt_time(h['time'])}"
                    for h in reached
                )
            )
    if not parts:
        return []
    return [
        "Predictability horizon (when the runs of one engine first spread that far): "
        + "; ".join(parts)
        + "."
    ]
