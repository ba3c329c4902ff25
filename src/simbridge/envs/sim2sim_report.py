"""The outputs of ``simbridge sim2sim``: the terminal headline (:func:`headline`), report.md
(:func:`markdown`), summary.json (:func:`summary`), the survival figure
(:mod:`.sim2sim_figures`), report.html (:mod:`.sim2sim_html`) and the replayed episode's
trajectories (:mod:`.sim2sim_replay`), written by :func:`write`.

report.md holds a headline per engine, the table of rates with Wilson intervals and McNemar
p-values against the training engine, returns and lengths with bootstrap intervals, survival,
clipped actions and sign changes, torque saturation and joint-limit hits, the failures by name
(NaN actions among them), the survival curves, the ranking of ``--explain`` where it ran, and
the contract table, engine beside engine, its rows marked where an engine departs from the
training engine; the open-loop replays where they ran (:mod:`.sim2sim_openloop_report`); for
a policy trained outside simbridge, every pair of engines and the stated contract as the
table's first column (:mod:`.sim2sim_external`).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from simbridge.envs import sim2sim_external, sim2sim_openloop_report
from simbridge.envs.sim2sim import ALPHA, TRAINED_FLOOR, EngineFigures, Sim2SimResult
from simbridge.envs.trained_on import outside

__all__ = ["contract_rows", "headline", "markdown", "summary", "write"]


def _rate(f: EngineFigures) -> str:
    r = f.rate
    return f"{r.successes}/{r.n} ({r.low:.2f}-{r.high:.2f})"


def headline(result: Sim2SimResult) -> list[str]:
    """One line per engine: its success, the interval, the verdict against the training engine.

    Args:
        result: the run.

    Returns:
        The lines (the training engine's first; a last line when it points at the contract).
    """
    if outside(result.trained_on):
        return sim2sim_external.headline(result)
    lines = []
    for i, f in enumerate(result.figures):
        if i == 0:
            what = "training engine"
        else:
            what = f"{f.verdict} against {result.figures[0].label} (McNemar p = {f.p_value:.3g})"
        nan = f", {f.nan_actions} NaN action(s)" if f.nan_actions else ""
        lines.append(f"{f.label}: success {_rate(f)}, {what}{nan}")
    if result.points_at_contract:
        lines.append(
            f"the policy succeeds on less than {TRAINED_FLOOR:.0%} of the seeds on its training "
            "engine: look at the contract (joint order, observation layout and scales, action "
            "meaning, gains, dt and decimation) before the engines"
        )
    return lines


def _joint_values(contract: dict[str, Any], key: str) -> str:
    return ", ".join(f"{j[key]:g}" for j in contract["action"]["joint_table"])


CONTACT_ENTRIES = (
    "lateral_friction",
    "read_urdf_contact",
    "solver_iterations",
    "apply_joint_damping",
    "max_joint_velocity",
    "enforce_effort_limit",
    "enforce_velocity_limit",
)
"""Profile entries the contract table always shows; any other entry shows where engines differ."""


def _settings_text(settings: dict[str, Any]) -> str:
    return ", ".join(f"{k} {v}" for k, v in settings.items())


def contract_rows(result: Sim2SimResult) -> list[tuple[str, list[str]]]:
    """The contract table's rows: a name and one value per engine (the task's contract, then
    the profile entries and engine settings each engine runs).

    Args:
        result: the run.

    Returns:
        ``(row name, [value per engine])`` in the table's order.
    """
    cs = [r.contract for r in result.runs]

    def row(name: str, fn: Any) -> tuple[str, list[str]]:
        return name, [str(fn(c)) for c in cs]

    return [
        row("backend", lambda c: c["backend"]),
        row("profile", lambda c: c["profile"]),
        row(
            "dt x decimation",
            lambda c: f"{c['timestep']:.6g} s x {c['decimation']} = {c['control_dt']:.6g} s",
        ),
        row("joint order (action)", lambda c: ", ".join(c["action"]["joints"])),
        row(
            "engine joint index",
            lambda c: ", ".join(str(j["index"]) for j in c["action"]["joint_table"]),
        ),
        row(
            "observation layout",
            lambda c: (
                ", ".join(f"{t['name']}[{t['size']}]" for t in c["observation"]["terms"])
                + f" x{c['observation']['history']}"
            ),
        ),
        row("observation normalisation", lambda c: _normalisation(c["observation"])),
        row("action meaning", lambda c: c["action"]["meaning"]),
        row(
            "gains kp / kd / max_force",
            lambda c: f"{c['action']['kp']} / {c['action']['kd']} / {c['action']['max_force']}",
        ),
        row("effort limit (joint table)", lambda c: _joint_values(c, "max_force")),
        row("velocity limit", lambda c: _joint_values(c, "max_velocity")),
        row("joint damping", lambda c: _joint_values(c, "damping")),
        row("joint friction", lambda c: _joint_values(c, "friction")),
        *_simulated_rows(cs),
    ]


def _normalisation(observation: dict[str, Any]) -> str:
    """The contract's observation statistics in words: none, the task's table or the file."""
    n = observation.get("normalisation")
    if not n:
        return "none"
    where = f"VecNormalize file {n['source']}" if n.get("source") else "the task's [normalisation]"
    return f"{where}: clip {n['clip']:g}, epsilon {n['epsilon']:g}"


def _simulated_rows(cs: list[dict[str, Any]]) -> list[tuple[str, list[str]]]:
    entries = [c["simulated"]["profile_entries"] for c in cs]
    keys = [
        k
        for k in entries[0]
        if k in CONTACT_ENTRIES or any(e.get(k) != entries[0][k] for e in entries)
    ]
    rows = [(f"profile: {k}", [str(e.get(k)) for e in entries]) for k in keys]
    rows.append(
        ("engine settings", [_settings_text(c["simulated"]["engine_settings"]) for c in cs])
    )
    return rows


def _rates_table(result: Sim2SimResult) -> list[str]:
    out = [
        "| engine | success (95% Wilson) | discordant (lost, won) | McNemar p | verdict | "
        "mean return (95% bootstrap) | return minus training | mean steps | "
        "not failed at 1/4, 1/2, 3/4, end | median time to failure | clipped steps | "
        "sign changes / step | physics steps at an effort limit | control steps at a joint limit |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for i, f in enumerate(result.figures):
        verdict = "training engine" if i == 0 else f.verdict
        mtf = "-" if f.median_failure_s is None else f"{f.median_failure_s:.2f} s"
        out.append(
            f"| {f.label} | {_rate(f)} | {f.discordant[0]}, {f.discordant[1]} | "
            f"{f.p_value:.3g} | {verdict} | {f.ret.value:.1f} ({f.ret.low:.1f} to "
            f"{f.ret.high:.1f}) | {f.ret_difference.value:+.1f} ({f.ret_difference.low:+.1f} "
            f"to {f.ret_difference.high:+.1f}) | {f.steps.value:.0f} ({f.steps.low:.0f}-"
            f"{f.steps.high:.0f}) | {', '.join(f'{s:.2f}' for s in f.survival)} | {mtf} | "
            f"{f.clipped_share:.1%} | {f.sign_changes:.2f} | {f.saturated_share:.1%} | "
            f"{f.limit_share:.1%} |"
        )
    return out


def _explain_lines(result: Sim2SimResult) -> list[str]:
    out = ["", "## Which setting recovers the success (--explain)", ""]
    if not result.explain:
        return out + ["No engine dropped significantly: nothing to explain.", ""]
    for e in result.explain:
        out.append(
            f"**{e['engine']}**: {e['before']}/{e['n']} against the training engine's "
            f"{e['training']}/{e['n']}."
        )
        out.append("")
        if e.get("note"):
            out += [e["note"], ""]
            continue
        out += [
            "| rank | setting moved toward the training engine | success after (95% Wilson) | "
            "p against before | share of the drop recovered | why |",
            "|---|---|---|---|---|---|",
        ]
        for c in e["candidates"]:
            lo, hi = c["interval"]
            tied = sum(o["rank"] == c["rank"] for o in e["candidates"]) > 1
            rank = f"{c['rank']}{'=' if tied else ''}"
            out.append(
                f"| {rank} | {c['setting']} | {c['successes']}/{e['n']} ({lo:.2f}-{hi:.2f}) | "
                f"{c['p_value']:.3g} | {c['recovered']:.0%} | {c['why']} |"
            )
        out.append("")
    return out


def _survival_lines(result: Sim2SimResult, figure: str | None) -> list[str]:
    """The time-to-failure section: the figure, and the replayed seed where one was chosen."""
    out = ["## Time to failure", ""]
    if figure is not None:
        out += [
            f"![Kaplan-Meier survival of every engine]({figure})",
            "",
            "Kaplan-Meier: an episode that ends on a termination fails at its length; one that "
            "succeeds early or reaches the episode's end is censored there. The band is the 95% "
            "log-log (Greenwood) interval.",
            "",
        ]
    out += [
        "Physics steps at an effort limit: the share of every physics step with an action "
        "joint's applied effort within 0.1% of its limit (the task's `max_force`, or the "
        "file's effort limit where smaller). Control steps at a joint limit: the share of the "
        "control steps after which a joint of the action robot is within 1 mm or 1 mrad of a "
        "position limit, or past it.",
        "",
    ]
    if result.replay is not None:
        out += [
            f"report.html replays {result.replay.why}. `simbridge replay` on this folder serves "
            "the same scene live.",
        ]
    return out


def markdown(result: Sim2SimResult, *, figure: str | None = None) -> str:
    """report.md's text.

    Args:
        result: the run.
        figure: the survival figure's file in the report folder; None: no figure.

    Returns:
        The Markdown.
    """
    n = len(result.seeds)
    ext = outside(result.trained_on)
    trained = (
        f"Trained outside simbridge (**{ext}**)" if ext else f"Trained on **{result.trained_on}**"
    )
    against = "every other engine" if ext else "the training engine"
    rates = _rates_table(result)
    lines = [
        f"# sim2sim: {result.policy} on {result.task}",
        "",
        f"{trained}; {n} paired episodes per engine (seeds "
        f"{result.seeds[0]}-{result.seeds[-1]}: the same initial states and commands on every "
        f"engine). Verdicts: McNemar's exact test on the discordant seeds against {against} "
        f"at p < {ALPHA}.",
        *(["", result.statistics.describe() + "."] if result.statistics is not None else []),
        "",
        *[f"- {line}" for line in headline(result)],
        "",
        "## Success and behaviour per engine",
        "",
        *(sim2sim_external.blank_paired_columns(rates) if ext else rates),
        "",
    ]
    for f in result.figures:
        if f.failures:
            named = ", ".join(f"{k} {v}" for k, v in sorted(f.failures.items()))
            lines.append(f"- {f.label} failures: {named}")
            if f.nan_actions:
                lines.append(
                    f"  - {f.nan_actions} episode(s) ended on a NaN or infinite action from the "
                    "policy, counted as failures and never passed to the engine"
                )
    lines += sim2sim_external.pairs_section(result)
    lines += [""] * (lines[-1] != "") + _survival_lines(result, figure)
    if not ext and (result.explain or any(f.verdict == "drop" for f in result.figures[1:])):
        lines += _explain_lines(result)
    lines += sim2sim_openloop_report.section(result.openloop)
    train = result.runs[0].contract
    labels, rows = sim2sim_external.with_stated(
        result, [f.label for f in result.figures], contract_rows(result)
    )
    lines += [
        "",
        "## The contract, engine beside engine",
        "",
        "| | " + " | ".join(labels) + " | departs |",
        "|---|" + "---|" * (len(labels) + 1),
    ]
    for name, values in rows:
        ref = values[1:] if values[0] == sim2sim_external.NOT_STATED else values  # engines alone
        departs = "yes" if any(v != ref[0] for v in ref[1:]) else ""
        if name in ("backend", "engine settings", "engine joint index", *sim2sim_external.UNREAD):
            departs = ""  # each backend's own
        lines.append(f"| {name} | " + " | ".join(values) + f" | {departs} |")
    said = f"The training engine's contract states the task {train['task']!r} ({train['source']})."
    if ext:
        said = (
            f"The stated column is the task {train['task']!r} ({train['source']}), the contract of "
            f"the training run outside simbridge ({ext}); a row it does not state is marked where "
            "the engines differ among themselves."
        )
    lines += ["", said, ""]
    return "\n".join(lines)


def summary(result: Sim2SimResult) -> dict[str, Any]:
    """summary.json's content.

    Args:
        result: the run.

    Returns:
        A JSON-ready dict: the inputs, per engine its figures and episodes, the explanation,
        every engine's contract.
    """
    engines = []
    for run, f in zip(result.runs, result.figures, strict=True):
        engines.append(
            {
                "label": f.label,
                "backend": run.engine.backend,
                "profile": run.engine.profile,
                "successes": f.rate.successes,
                "n": f.rate.n,
                "interval": [f.rate.low, f.rate.high],
                "discordant": list(f.discordant),
                "p_value": f.p_value,
                "verdict": f.verdict,
                "return": f.ret._asdict(),
                "return_difference": f.ret_difference._asdict(),
                "steps": f.steps._asdict(),
                "survival_quarters": f.survival,
                "median_time_to_failure_s": f.median_failure_s,
                "failures": f.failures,
                "nan_actions": f.nan_actions,
                "clipped_share": f.clipped_share,
                "sign_changes_per_step": f.sign_changes,
                "saturated_share": f.saturated_share,
                "limit_share": f.limit_share,
                "survival_curve": _curve(run),
                "wall_s": run.wall_s,
                "episodes": [r._asdict() for r in run.records],
                "contract": run.contract,
            }
        )
    if outside(result.trained_on):  # no training engine: every pair is in "external"
        for e in engines:
            e.update(dict.fromkeys(sim2sim_external.PAIRED_FIELDS))
    return {
        "task": result.task,
        "policy": result.policy,
        "trained_on": result.trained_on,
        "seeds": result.seeds,
        "alpha": ALPHA,
        "points_at_contract": result.points_at_contract,
        "headline": headline(result),
        "engines": engines,
        "explain": result.explain,
        "normalisation": None if result.statistics is None else result.statistics.as_dict(),
        "openloop": sim2sim_openloop_report.summary(result.openloop),
        "external": sim2sim_external.summary(result, contract_rows(result)),
        "replay": _replay_dict(result),
    }


def _curve(run: Any) -> dict[str, list[float]]:
    """An engine's Kaplan-Meier curve, JSON-ready (control steps and their survival)."""
    from simbridge.envs.survival import kaplan_meier

    km = kaplan_meier(run.records)
    return {
        "steps": km.times.tolist(),
        "survival": km.survival.tolist(),
        "low": km.low.tolist(),
        "high": km.high.tolist(),
    }


def _replay_dict(result: Sim2SimResult) -> dict[str, Any] | None:
    r = result.replay
    if r is None:
        return None
    from simbridge.compare.report.fmt import file_stem

    return {
        "seed": r.seed,
        "why": r.why,
        "matches_evaluation": dict(zip([f.label for f in result.figures], r.matches, strict=True)),
        "trajectories": [f"trajectories/{file_stem(f.label)}.npz" for f in result.figures],
    }


def write(result: Sim2SimResult, out: Path, *, html: bool = True) -> list[Path]:
    """Write report.md, summary.json, the survival figure and, with ``html``, report.html into
    ``out`` (made if missing); with ``result.replay`` (:mod:`.sim2sim_replay`) also its
    trajectories (``trajectories/<engine>.npz``), which report.html's 3D replay draws.

    Args:
        result: the run.
        out: the folder.
        html: False: no report.html.

    Returns:
        The files written: report.md, summary.json, then the figure, report.html and the
        trajectories.
    """
    from simbridge.envs.sim2sim_figures import FIGURE, survival_figure

    out.mkdir(parents=True, exist_ok=True)
    md, js = out / "report.md", out / "summary.json"
    figure = survival_figure(result, out / FIGURE)
    text = markdown(result, figure=FIGURE)
    md.write_text(text, encoding="utf-8")
    js.write_text(json.dumps(summary(result), indent=2) + "\n", encoding="utf-8")
    files = [md, js, figure]
    if html:
        from simbridge.envs.sim2sim_html import write_html

        files.append(write_html(result, text, out))
    if result.replay is not None:
        from simbridge.envs.sim2sim_replay import save

        files += save(result.replay, [f.label for f in result.figures], out)
    return files
