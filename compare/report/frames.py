"""Key frames and a moving picture of the nominal runs, for ``report.md``: :func:`write_frames`.

Every picture is drawn by one renderer from the recorded poses, never by the engines that ran:
a PyBullet :class:`simbridge.Sim` (its ``render``, TinyRenderer on the CPU) holds the
scenario's robots, each posed at every drawn instant from an engine's trajectory (the root
link's world pose and the movable joints' positions), so any difference between two engines'
pictures is their motion, not their rendering. Each engine gets a panel under a header in its
plots' colour; the camera follows that engine's robot (the middle of the box that holds it as
drawn) from the same direction and distance in every panel and every frame, the distance the
nearest at which the robot fits every panel and frame (:func:`_framing`).

Drawn: the start, the end, and the instants of the events the report finds (the first event of
each kind in each engine and the instant the gap is born, events within 2 % of the run merged
into one frame, at most :data:`MAX_KEY_EVENTS` frames), as one PNG per instant; and an animated
GIF of the whole run (at most :data:`GIF_FRAMES` frames).
"""

from __future__ import annotations

import math
import time as _time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..analysis.diff import QUANTITIES
from ..pipeline import Comparison
from ..run.portable import dot
from ..run.quantities import up_axis
from ..run.trajectory import Trajectory
from .events import event_words
from .fmt import fmt_distance, fmt_threshold, fmt_time

__all__ = [
    "Frames",
    "KeyFrame",
    "write_frames",
    "panel_header",
    "key_instants",
    "frames_section",
    "PANEL",
    "GIF_FRAMES",
    "MAX_KEY_EVENTS",
]

PANEL = (224, 168)
"""Pixels of one engine's picture (width, height), its header apart."""
HEADER = 18
"""Pixels of the header above each panel (the engine, the time, the height)."""
GIF_FRAMES = 30
"""The most frames of the animation (a longer run is sampled more sparsely)."""
GIF_FPS = 10.0
"""Frames per simulated second of the animation, below :data:`GIF_FRAMES`."""
MAX_KEY_EVENTS = 6
"""The most key frames at events (the start and the end come besides)."""
MERGE = 0.02
"""Events closer than this fraction of the run (and 0.05 s) share one key frame."""
ORDER = (
    "tipped_over",
    "airborne",
    "peak_height",
    "contact_made",
    "joint_limit",
    "contact_chatter",
    "contact_lost",
    "motor_saturated",
)
"""Which events get a key frame first when there are more than :data:`MAX_KEY_EVENTS`
(the instant the gap is born before them all)."""
CAMERA_AZIMUTH = -50.0
"""Degrees about the world's up, from the world's x axis, of the camera's side."""
CAMERA_ELEVATION = 22.0
"""Degrees above the horizontal the camera looks down from."""
FOV = 50.0
"""Degrees: the camera's vertical field of view."""
FILL = 0.85
"""The share of a panel's half-width and half-height the robot takes at most (the camera's
distance: :func:`_framing`)."""
MIN_DISTANCE = 0.2
"""Metres: the camera's nearest (a robot of a few centimetres)."""
MAX_GROWTH = 4.0
"""The camera's distance is at most this many times the start's (a diverged run's poses)."""


@dataclass
class KeyFrame:
    """One still: every engine at ``time`` (s), ``file`` (under the report folder), and the
    events it shows in words (empty at the start and the end)."""

    time: float
    file: str
    events: list[str] = field(default_factory=list)
    title: str = ""


@dataclass
class Frames:
    """What :func:`write_frames` drew: the stills, the animation (a file name under the report
    folder; None when none was drawn), the events left without a frame of their own, the
    seconds it took, and why nothing was drawn (``note``; None when it was)."""

    key_frames: list[KeyFrame] = field(default_factory=list)
    animation: str | None = None
    animation_frames: int = 0
    animation_speed: float = 1.0
    left_out: int = 0
    seconds: float = 0.0
    note: str | None = None
    files: list[str] = field(default_factory=list)


# ---------------------------------------------------------------- which instants


def key_instants(s: dict[str, Any], duration: float) -> tuple[list[KeyFrame], int]:
    """The instants of the events a key frame is drawn at, from ``summary.json``'s dict ``s``:
    the instant the gap is born, then the first event of each kind in each engine (in
    :data:`ORDER`); an event within :data:`MERGE` of the run of a chosen instant joins its
    frame. Returns the frames (by time, files not yet named) and how many events were left
    without one (past :data:`MAX_KEY_EVENTS`)."""
    candidates: list[tuple[int, float, str]] = []
    p = s.get("parting") or {}
    if p.get("time") is not None:
        q = QUANTITIES[p["quantity"]]
        words = f"the {q.title} first reaches {fmt_threshold(p['threshold'], q.unit)}"
        candidates.append((-1, float(p["time"]), words))
    for label, ev in (s.get("events") or {}).items():
        seen: set[str] = set()
        for e in ev["events"]:
            if e["kind"] in seen or e["kind"] not in ORDER:
                continue
            seen.add(e["kind"])
            candidates.append((ORDER.index(e["kind"]), float(e["time"]), event_words(e, label)))
    candidates.sort(key=lambda x: (x[0], x[1]))
    window = max(0.05, MERGE * duration)
    chosen: list[KeyFrame] = []
    left = 0
    times: dict[int, list[tuple[float, str]]] = {}
    for _, t, words in candidates:
        near = [k for k in chosen if abs(k.time - t) <= window]
        if near:
            times[id(near[0])].append((t, words))
        elif len(chosen) < MAX_KEY_EVENTS:
            chosen.append(KeyFrame(t, ""))
            times[id(chosen[-1])] = [(t, words)]
        else:
            left += 1
    for k in chosen:  # by time, each merged one with its own
        said = sorted(times[id(k)], key=lambda x: x[0])
        k.events = [w if t == k.time else f"{w} (t = {fmt_time(t)})" for t, w in said]
    chosen.sort(key=lambda k: k.time)
    return chosen, left


# ---------------------------------------------------------------- drawing


@dataclass
class _Posed:
    """One robot loaded in the drawing Sim: its body, the movable 1-DoF joints the
    trajectory's columns ``cols`` hold (a spherical joint is left as loaded), and its base's
    centre-of-mass frame in its root link's frame (the trajectory records the root link's pose;
    a teleport takes the former)."""

    name: str
    body: int
    joints: list[int]
    cols: list[int]
    inertial: tuple[tuple[float, float, float], tuple[float, float, float, float]]


class _Painter:
    """A PyBullet Sim with the scenario's robots, posed from a trajectory and drawn."""

    def __init__(self, c: Comparison) -> None:
        import simbridge

        sc = c.scenario
        self.sim = simbridge.Sim("pybullet", gravity=sc.gravity)
        try:
            first = c.runs[(0, c.timestep)]
            self.robots: list[_Posed] = []
            for r in sc.robots:
                body = sc.load_robot(self.sim, r)
                rec = first.bodies.get(r.name)
                joints: list[int] = []
                cols: list[int] = []
                if rec is not None:
                    for col, j in enumerate(rec.joint_indices):
                        kind = self.sim.joint_info(body, int(j)).type.name
                        if kind in ("REVOLUTE", "PRISMATIC"):
                            joints.append(int(j))
                            cols.append(col)
                base = self.sim.link_state(body, -1)
                self.robots.append(
                    _Posed(
                        r.name,
                        body,
                        joints,
                        cols,
                        (base.local_inertial_position, base.local_inertial_orientation),
                    )
                )
        except BaseException:
            self.sim.close()
            raise
        self.up = up_axis(sc.gravity)

    def close(self) -> None:
        self.sim.close()

    def pose(self, tr: Trajectory, row: int) -> None:
        from simbridge.transforms import transform_multiply

        for r in self.robots:
            rec = tr.bodies.get(r.name)
            if rec is None:
                continue
            row_r = min(row, len(rec.base_position) - 1)
            if not rec.fixed_base:
                pos, orn = transform_multiply(
                    (rec.base_position[row_r], rec.base_orientation[row_r]), r.inertial
                )
                self.sim.reset_base_state(r.body, position=pos, orientation=orn)
            if r.joints:
                q = rec.joint_positions[row_r, r.cols]
                self.sim.reset_joint_state(r.body, r.joints, [float(x) for x in q])

    def draw(self, target: np.ndarray, distance: float) -> np.ndarray:
        eye = target + distance * _direction(self.up)
        w, h = PANEL
        up = tuple(float(x) for x in self.up)
        return self.sim.render(w, h, eye=eye.tolist(), target=target.tolist(), up=up, fov=FOV)


def _direction(up: np.ndarray) -> np.ndarray:
    """Unit vector from the target to the camera: :data:`CAMERA_AZIMUTH` about ``up`` from the
    world's x axis (y when x is up), :data:`CAMERA_ELEVATION` above the horizontal."""
    ref = np.array([1.0, 0.0, 0.0]) if abs(up[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    forward = ref - up * float(ref @ up)
    forward /= np.linalg.norm(forward)
    side = np.cross(up, forward)
    az, el = math.radians(CAMERA_AZIMUTH), math.radians(CAMERA_ELEVATION)
    horizontal = math.cos(az) * forward + math.sin(az) * side
    return math.cos(el) * horizontal + math.sin(el) * up


@dataclass
class _View:
    """Where each panel looks (by engine slot and row) and the camera's distance, the same in
    every panel and frame."""

    targets: dict[tuple[int, int], np.ndarray]
    distance: float


def _framing(c: Comparison, times: list[float], up: np.ndarray) -> _View:
    """The camera on the subject robot at each drawn instant: it looks at the middle of the
    box that holds the robot as drawn (:func:`~.replay.body_points`: its visuals' boxes), from
    the distance at which the robot, in every panel and frame, fills at most :data:`FILL` of
    the panel's width and height (the points nearer the camera counted larger). A distance
    over :data:`MAX_GROWTH` times the start's (a run that diverged) is cut to that."""
    from .replay import body_points

    back = _direction(up)  # from the target to the camera
    right = np.cross(-back, up)
    right /= np.linalg.norm(right)
    above = np.cross(right, -back)
    tan_v = math.tan(math.radians(FOV) / 2) * FILL
    tan_h = tan_v * PANEL[0] / PANEL[1]
    targets: dict[tuple[int, int], np.ndarray] = {}
    start, need = MIN_DISTANCE, MIN_DISTANCE
    for slot in range(len(c.labels)):
        tr = c.runs[(slot, c.timestep)]
        rows = sorted({_row(tr, t) for t in times})
        points = body_points(tr, tr.subject, np.asarray(rows))
        for row, p in zip(rows, points, strict=True):
            p = p[np.isfinite(p).all(axis=1)]
            links = tr.body.link_positions[min(row, len(tr.body.link_positions) - 1)]
            if not len(p):  # a diverged pose: its links' mean, as drawn before
                targets[(slot, row)] = np.asarray(links.mean(axis=0), dtype=np.float64)
                continue
            centre = (p.min(axis=0) + p.max(axis=0)) / 2
            targets[(slot, row)] = centre
            off = p - centre
            d = off @ back + np.maximum(np.abs(off @ right) / tan_h, np.abs(off @ above) / tan_v)
            far = float(d.max())
            need = max(need, far)
            if row == rows[0]:
                start = max(start, far)
    return _View(targets, min(need, MAX_GROWTH * start))


def _colour(slot: int) -> tuple[int, int, int]:
    from matplotlib.colors import to_rgb

    from .plots import COLORS

    r, g, b = to_rgb(COLORS[slot % len(COLORS)])
    return round(r * 255), round(g * 255), round(b * 255)


def _strip(c: Comparison, painter: _Painter, time: float, view: _View) -> Any:
    """Every engine at ``time``, side by side, each under its header: a PIL image."""
    from PIL import Image, ImageDraw, ImageFont

    w, h = PANEL
    n = len(c.labels)
    image = Image.new("RGB", (w * n, h + HEADER), (255, 255, 255))
    draw = ImageDraw.Draw(image)
    font = _font(ImageFont)
    for slot, label in enumerate(c.labels):
        tr = c.runs[(slot, c.timestep)]
        row = _row(tr, time)
        painter.pose(tr, row)
        target = view.targets[(slot, row)]
        image.paste(Image.fromarray(painter.draw(target, view.distance)), (slot * w, HEADER))
        draw.rectangle((slot * w, 0, (slot + 1) * w - 1, HEADER - 1), fill=_colour(slot))
        height = float(
            dot(tr.body.base_position[min(row, len(tr.body.base_position) - 1)], painter.up)
        )
        text = panel_header(label, float(tr.time[row]), height)
        draw.text((slot * w + 4, 2), text, fill=(255, 255, 255), font=font)
        if slot:
            draw.line((slot * w, 0, slot * w, h + HEADER), fill=(255, 255, 255), width=2)
    return image


def panel_header(label: str, time: float, height: float) -> str:
    """A panel's header: the engine, the time as the frame's caption writes it (to the
    millisecond: two frames at different instants never read alike), the base's height."""
    return f"{label}  t = {fmt_time(time)}  base at {fmt_distance(height)}"


def _font(module: Any) -> Any:
    try:
        return module.load_default(size=12)
    except (TypeError, OSError):  # a Pillow without FreeType: the bitmap font
        return module.load_default()


def _row(tr: Trajectory, time: float) -> int:
    found = int(np.searchsorted(tr.time, time - 1e-9))
    return min(len(tr.time) - 1, max(0, found))


# ---------------------------------------------------------------- writing


def write_frames(c: Comparison, s: dict[str, Any], out: Path, folder: str = "frames") -> Frames:
    """Draw the key frames (``<folder>/start.png``, ``t<seconds>.png`` at each event instant,
    ``end.png``) and the animation (``<folder>/replay.gif``) of ``c``'s nominal runs at the
    headline time step into ``out``; ``s`` is the comparison's ``summary.json`` dict (its events
    and parting). Nothing is drawn, and ``note`` says why, when the drawing Sim cannot be made
    or cannot load the scenario's robots."""
    from simbridge.exceptions import SimbridgeError

    t0 = _time.perf_counter()
    duration = max(float(c.runs[(slot, c.timestep)].time[-1]) for slot in range(len(c.labels)))
    try:
        painter = _Painter(c)
    except SimbridgeError as exc:
        return Frames(note=f"no pictures drawn: {exc}", seconds=_time.perf_counter() - t0)
    result = Frames()
    try:
        _draw(c, s, out, folder, painter, duration, result)
    except SimbridgeError as exc:  # a pose the drawing Sim refuses (a diverged run's NaN)
        return Frames(note=f"no pictures drawn: {exc}", seconds=_time.perf_counter() - t0)
    finally:
        painter.close()
    result.files = [k.file for k in result.key_frames]
    if result.animation:
        result.files.append(result.animation)
    result.seconds = _time.perf_counter() - t0
    return result


def _draw(
    c: Comparison,
    s: dict[str, Any],
    out: Path,
    folder: str,
    painter: _Painter,
    duration: float,
    result: Frames,
) -> None:
    """:func:`write_frames`'s drawing, into ``result``."""
    (out / folder).mkdir(parents=True, exist_ok=True)
    events, result.left_out = key_instants(s, duration)
    stills = [KeyFrame(0.0, "", [], "the start"), *events]
    stills.append(KeyFrame(duration, "", [], "the end"))
    n = max(2, min(GIF_FRAMES, int(duration * GIF_FPS) + 1))
    times = np.linspace(0.0, duration, n)
    times[-1] = duration  # exactly: the end's still
    view = _framing(c, [k.time for k in stills] + [float(t) for t in times], painter.up)
    drawn: dict[float, Any] = {}  # the start and the end are the animation's first and last

    def strip(time: float) -> Any:
        if time not in drawn:
            drawn[time] = _strip(c, painter, time, view)
        return drawn[time]

    for k in stills:
        name = "start" if k.title == "the start" else "end" if k.title == "the end" else None
        k.file = f"{folder}/{name or f't{k.time:.3f}'.replace('.', '_')}.png"
        strip(k.time).save(out / k.file)
    result.key_frames = stills
    pictures = [strip(float(t)) for t in times]
    step_ms = 1000.0 * duration / (n - 1)
    shown_ms = min(max(step_ms, 60.0), 200.0)
    result.animation_speed = step_ms / shown_ms
    ms = [round(shown_ms)] * (n - 1) + [1500]  # the end held
    frames = [p.quantize(colors=128, method=2) for p in pictures]  # median cut
    result.animation = f"{folder}/replay.gif"
    frames[0].save(
        out / result.animation,
        save_all=True,
        append_images=frames[1:],
        duration=ms,
        loop=0,
        optimize=False,
    )
    result.animation_frames = n


def frames_section(f: Frames, subject: str, labels: tuple[str, ...]) -> list[str]:
    """``report.md``'s section of the pictures (empty when none was asked for)."""
    lines = ["## The runs, seen", ""]
    if f.note is not None:
        return lines + [f"No pictures: {f.note}.", ""]
    lines += [
        f"Each engine's nominal run, {', '.join(labels)} from left to right, drawn by one "
        "renderer (PyBullet's TinyRenderer) from the recorded poses (every robot's root link "
        "and joint positions), so what differs between the panels is the motion. The camera "
        f"follows each engine's {subject} from the same direction and distance; the header gives "
        "the time and the height of the base.",
        "",
    ]
    if f.animation:
        speed = "" if abs(f.animation_speed - 1.0) < 0.05 else f", {f.animation_speed:.2g}x speed"
        lines += [
            f"![the nominal runs]({f.animation})",
            "",
            f"*The whole run in {f.animation_frames} frames{speed}.*",
            "",
        ]
    lines += ["### Key frames", ""]
    for k in f.key_frames:
        when = f"t = {fmt_time(k.time)}"
        if k.title:
            lines += [f"**{when}, {k.title}.**", ""]
        else:
            lines += [f"**{when}**: " + "; ".join(k.events) + ".", ""]
        lines += [f"![{when}]({k.file})", ""]
    if f.left_out:
        lines += [
            f"{f.left_out} more events (first of their kind) without a frame of their own; every "
            "event is in `summary.json` under `events`.",
            "",
        ]
    return lines
