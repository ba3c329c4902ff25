"""The 3D replay of a comparison: every engine's recorded nominal run overlaid in one scene,
drawn by viser (a three.js viewer) from the recorded poses, no engine needed.

* :func:`replay_engines` gathers what a replay shows from a
  :class:`~simbridge.compare.pipeline.Comparison` (each engine's nominal run at the headline
  time step, its events and its ensemble's perturbed members), :func:`engines_from_report` the
  same from a report folder already written (``trajectories/*.npz``, ``replay_ghosts.npz``);
* :func:`replay_html` records the scene into one self-contained HTML document (viser's
  client bundle and the zstd-compressed recording inlined: it opens from disk, offline), with
  the viewer's own playback bar: time scrubber, play and pause, speed, and the scene tree whose
  eye icons hide or show each engine;
* :func:`serve` shows the same scene live from a viser server, with the controls in its panel
  (``simbridge replay REPORT_DIR``).

Each engine's robots get the robot's own meshes and colours (the URDF's ``<visual>`` elements
read through simbridge's URDF model; meshes through :func:`simbridge.model.meshes.read_mesh`),
tinted
towards the engine's colour; static bodies (a plane) are drawn once, grey, under a grid on
z = 0. Every link's pose is computed from the recorded base pose and joint positions along the
URDF's joints (the URDF link frames the visuals are given in). Events
(:func:`~simbridge.compare.run.events.find_events`) become markers in the scene from the
instant they happen, and :func:`event_marks` lists them for the page's buttons.

viser is the extra ``simbridge[report]``: without it :func:`available` is False and the
report says how to get the replay.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..run.events import EngineEvents, find_events
from ..run.trajectory import BodyTrajectory, Trajectory
from .fmt import file_stem
from .replay_models import (
    CAMERA_FOV,
    LinkVisual,
    body_points,
    camera_view,
    link_poses,
    link_visuals,
    quat_wxyz,
    read_model,
    urdf_sources,
)

__all__ = [
    "ENGINE_COLOURS",
    "MARK_KINDS",
    "EventMark",
    "ReplayEngine",
    "available",
    "body_points",
    "camera_view",
    "CAMERA_FOV",
    "link_poses",
    "engines_from_report",
    "event_marks",
    "frame_rows",
    "replay_engines",
    "replay_html",
    "serve",
    "GHOSTS_FILE",
]

ENGINE_COLOURS = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b")
"""One colour per engine, in the comparison's order (matplotlib's, as in the plots)."""

MARK_KINDS = (
    "contact_made",
    "contact_lost",
    "contact_chatter",
    "airborne",
    "peak_height",
    "tipped_over",
    "joint_limit",
)
"""The event kinds marked in the replay (a saturated motor is left to the report's text: it
happens tens of times a run)."""

MAX_FRAMES = 240
"""Frames recorded per replay at most (the scrubber's resolution); see :func:`frame_rows`."""
FPS = 30.0
"""Frames per simulated second at most."""
GHOSTS_FILE = "replay_ghosts.npz"
"""The ensembles' perturbed members' positions at the replay's frames, in the report folder."""


def available() -> bool:
    """Whether viser (``simbridge[report]``) is installed."""
    import importlib.util

    return importlib.util.find_spec("viser") is not None


@dataclass
class ReplayEngine:
    """One engine in the replay: its label, colour, nominal run, events and the positions of its
    ensemble's perturbed members (``ghosts`` (M, F, P, 3) at ``ghost_rows`` (F,) rows of the
    nominal run; None without an ensemble)."""

    label: str
    colour: str
    trajectory: Trajectory
    events: EngineEvents
    ghosts: np.ndarray | None = None
    ghost_rows: np.ndarray | None = None


@dataclass(frozen=True)
class EventMark:
    """Events of one engine, one kind, at one instant (the links involved merged)."""

    engine: int
    label: str
    kind: str
    time: float
    row: int
    parts: tuple[str, ...]
    position: tuple[float, float, float]
    words: str = field(default="")


def _engine_colour(slot: int) -> str:
    return ENGINE_COLOURS[slot % len(ENGINE_COLOURS)]


def replay_engines(comparison: Any, *, ghosts: bool = True) -> list[ReplayEngine]:
    """Each engine of ``comparison`` (a :class:`~simbridge.compare.pipeline.Comparison`): its
    nominal run at the headline time step, its events and, with ``ghosts``, the positions its
    ensemble kept of the perturbed members (the headline quantity's, when they are positions)."""
    out = []
    for slot, label in enumerate(comparison.labels):
        tr = comparison.runs[(slot, comparison.timestep)]
        g = rows = None
        if ghosts and slot < len(comparison.ensembles):
            g, rows = _ghosts_of(comparison.ensembles[slot], tr)
        out.append(
            ReplayEngine(label, _engine_colour(slot), tr, find_events(tr, label=label), g, rows)
        )
    return out


def _ghosts_of(ensemble: Any, tr: Trajectory) -> tuple[np.ndarray | None, np.ndarray | None]:
    """(M, F, P, 3) positions of the perturbed members at the replay's frames and those rows;
    (None, None) when the ensemble kept no positions (a joint quantity) or has no member."""
    f = np.asarray(ensemble.features)
    if f.shape[0] < 2 or f.shape[-1] != 3 or f.ndim not in (3, 4):
        return None, None
    rows = frame_rows(tr)
    idx = np.clip(np.searchsorted(np.asarray(ensemble.rows), rows), 0, f.shape[1] - 1)
    members = f[1:, idx]
    if members.ndim == 3:
        members = members[:, :, None, :]
    return members.astype(np.float32), rows


def frame_rows(tr: Trajectory, *, max_frames: int = MAX_FRAMES, fps: float = FPS) -> np.ndarray:
    """The rows of ``tr`` the replay shows: evenly spaced, at most ``fps`` per simulated second
    and ``max_frames`` in all, the first and the last row always included."""
    n = len(tr.time)
    if n <= 1:
        return np.zeros(1, dtype=int)
    frames = int(min(max_frames, max(2, math.ceil(tr.duration * fps) + 1), n))
    return np.unique(np.round(np.linspace(0, n - 1, frames)).astype(int))


def event_marks(engines: list[ReplayEngine]) -> list[EventMark]:
    """The events of :data:`MARK_KINDS`, one mark per engine, kind and instant, in time order
    (ties: the engines' order), each placed at its link's position (the base's for a whole-body
    event)."""
    from .events import event_words
    from .summary_json import event_dict

    marks = []
    for slot, eng in enumerate(engines):
        groups: dict[tuple[str, int], list[Any]] = {}
        for e in eng.events.events:
            if e.kind in MARK_KINDS:
                groups.setdefault((e.kind, e.row), []).append(e)
        b = eng.trajectory.bodies[eng.events.body]
        for (kind, row), evs in groups.items():
            parts = tuple(e.part for e in evs if e.part)
            pos = b.base_position[row]
            if parts and parts[0] in b.link_names:
                pos = b.link_positions[row, b.link_names.index(parts[0])]
            words = event_words(event_dict(evs[0]), eng.label)
            if len(parts) > 1:
                words += f" (and {', '.join(parts[1:])})"
            marks.append(
                EventMark(
                    slot,
                    eng.label,
                    kind,
                    float(evs[0].time),
                    int(row),
                    parts,
                    (float(pos[0]), float(pos[1]), float(pos[2])),
                    words,
                )
            )
    marks.sort(key=lambda m: (m.time, m.engine))
    return marks


# ------------------------------------------------------------------ robots and their poses


def _static(b: BodyTrajectory) -> bool:
    """A body that never moves (no joint, its base still): scenery."""
    return (
        len(b.joint_names) == 0
        and bool(np.ptp(b.base_position, axis=0).max() < 1e-9)
        and bool(np.ptp(b.base_orientation, axis=0).max() < 1e-9)
    )


def _rgb(colour: str) -> np.ndarray:
    return np.array([int(colour[i : i + 2], 16) for i in (1, 3, 5)], dtype=float) / 255.0


TINT_FLOOR = 0.4
"""A visual's tint is the engine's colour scaled by ``TINT_FLOOR + (1 - TINT_FLOOR) * its
luminance``: every part of a robot takes its engine's hue (the legend's), its light parts the
colour itself, its dark parts a darker shade of it, so the robot's shape still reads. (A mix
of 45% of the visual's colour with 55% of the engine's, as before, left r2d2's blue and white
body near the same on every engine: the engines told apart only by the legend.)"""


def _tint(rgba: tuple[float, ...], colour: str) -> tuple[int, int, int]:
    r, g, b = (float(x) for x in rgba[:3])
    luminance = 0.299 * r + 0.587 * g + 0.114 * b  # Rec. 601
    c = _rgb(colour) * (TINT_FLOOR + (1.0 - TINT_FLOOR) * luminance)
    return tuple(int(round(255 * x)) for x in np.clip(c, 0, 1))  # type: ignore[return-value]


def _name(text: str) -> str:
    return "".join(ch if ch.isalnum() or ch in "-_" else "_" for ch in text)


# ------------------------------------------------------------------ the scene


@dataclass
class _Node:
    """A moving frame: its handle and its poses at every frame."""

    handle: Any
    positions: np.ndarray  # (F, 3)
    wxyz: np.ndarray  # (F, 4)


class _Scene:
    """The replay's scene on a viser server: robots, ground, markers; :meth:`show` puts every
    engine at frame ``k``."""

    def __init__(self, server: Any, engines: list[ReplayEngine], *, ghosts: bool = True):
        self.server = server
        self.engines = engines
        ref = engines[0].trajectory
        self.rows = frame_rows(ref)
        self.times = ref.time[self.rows] - ref.time[0]
        self.nodes: list[_Node] = []
        self.ghosts: list[tuple[Any, np.ndarray]] = []
        self.marks = event_marks(engines)
        self.roots: dict[str, tuple[Any, Any]] = {}
        self.extent: list[np.ndarray] = []  # (F, P, 3) each: what bounds a moving body
        scene = server.scene
        scene.set_up_direction("+z")
        scene.add_grid(
            "/ground/grid",
            width=20.0,
            height=20.0,
            cell_size=0.25,
            section_size=1.0,
            position=(0.0, 0.0, 0.0005),
        )
        models: dict[str, Any] = {}
        drawn_static: set[str] = set()
        for eng in engines:
            tr = eng.trajectory
            rows = self._rows_of(tr)
            root = f"/{_name(eng.label)}"
            self.roots[eng.label] = (
                scene.add_frame(root, show_axes=False),
                scene.add_frame(f"/events/{_name(eng.label)}", show_axes=False),
            )
            for (name, b), src in zip(tr.bodies.items(), urdf_sources(tr), strict=True):
                if src not in models:
                    models[src or ""] = read_model(src)
                model = models[src or ""]
                if _static(b):
                    if name not in drawn_static and model is not None:
                        drawn_static.add(name)
                        self._static_body(f"/ground/{_name(name)}", model, b)
                    continue
                self._body(f"{root}/{_name(name)}", model, b, rows, eng.colour)
                self.extent.append(body_points(tr, name, rows))
            if ghosts and eng.ghosts is not None:
                g = eng.ghosts  # (M, F, P, 3)
                pts = g[:, 0].reshape(-1, 3)
                h = scene.add_point_cloud(
                    f"{root}/ensemble",
                    points=pts,
                    colors=tuple(int(255 * (0.6 + 0.4 * c)) for c in _rgb(eng.colour)),
                    point_size=0.03,
                    point_shape="circle",
                    precision="float32",
                )
                self.ghosts.append((h, g))
        self._camera()

    def _rows_of(self, tr: Trajectory) -> np.ndarray:
        """The rows of ``tr`` at the replay's frame times (engines share the time step here, but
        a run cut short keeps its last row)."""
        t = tr.time - tr.time[0]
        return np.clip(np.searchsorted(t, self.times - 1e-9), 0, len(t) - 1)

    def _static_body(self, path: str, model: Any, b: BodyTrajectory) -> None:
        frames = link_poses(model, b, np.zeros(1, dtype=int))
        for i, v in enumerate(link_visuals(model)):
            if len(v.vertices) > 20000:
                continue
            pos, rot = frames[v.link]
            verts = v.vertices @ rot[0].T + pos[0]
            if np.ptp(verts, axis=0).max() > 50:  # a ground plane: the grid stands for it
                continue
            self.server.scene.add_mesh_simple(
                f"{path}/v{i}", verts, v.faces, color=(200, 200, 200), side="double"
            )

    def _body(
        self, path: str, model: Any, b: BodyTrajectory, rows: np.ndarray, colour: str
    ) -> None:
        scene = self.server.scene
        if model is None:  # not a URDF (an MJCF body): a sphere at each link's centre of mass
            for k, link in enumerate(b.link_names):
                h = scene.add_icosphere(
                    f"{path}/{_name(link)}", radius=0.03, color=_tint((0.7, 0.7, 0.7), colour)
                )
                pos = b.link_positions[rows, k]
                wxyz = np.tile([1.0, 0.0, 0.0, 0.0], (len(rows), 1))
                self.nodes.append(_Node(h, pos, wxyz))
            return
        frames = link_poses(model, b, rows)
        by_link: dict[int, list[LinkVisual]] = {}
        for v in link_visuals(model):
            by_link.setdefault(v.link, []).append(v)
        for link in model.links:
            pos, rot = frames[link.index]
            h = scene.add_frame(
                f"{path}/{_name(link.name)}",
                show_axes=False,
                position=tuple(pos[0]),
                wxyz=tuple(quat_wxyz(rot[:1])[0]),
            )
            self.nodes.append(_Node(h, pos, quat_wxyz(rot)))
            for i, v in enumerate(by_link.get(link.index, [])):
                scene.add_mesh_simple(
                    f"{path}/{_name(link.name)}/v{i}",
                    v.vertices,
                    v.faces,
                    color=_tint(v.rgba, colour),
                    opacity=None if v.rgba[3] >= 1 else float(v.rgba[3]),
                )

    def _camera(self) -> None:
        """Look at the moving robots from the side and above, from as near as holds them
        (:func:`camera_view`)."""
        view = camera_view(self.extent)
        if view is None:
            return
        cam = self.server.initial_camera
        cam.look_at, cam.position = view

    def show(self, k: int) -> None:
        """Every engine at frame ``k``."""
        for n in self.nodes:
            n.handle.position = tuple(float(x) for x in n.positions[k])
            n.handle.wxyz = tuple(float(x) for x in n.wxyz[k])
        for h, g in self.ghosts:
            h.points = g[:, min(k, g.shape[1] - 1)].reshape(-1, 3)

    def add_mark(self, i: int, m: EventMark) -> None:
        colour = _rgb(_engine_colour(m.engine))
        self.server.scene.add_icosphere(
            f"/events/{_name(m.label)}/e{i}_{m.kind}",
            radius=0.025,
            color=tuple(int(255 * c) for c in colour),
            position=m.position,
        )


def replay_html(engines: list[ReplayEngine], *, ghosts: bool = True) -> str:
    """The replay as one self-contained HTML document (viser's client with the recorded scene
    inlined): the engines' runs overlaid, event markers appearing at their instants; recording
    time is simulated time."""
    server = _quiet_server()
    try:
        scene = _Scene(server, engines, ghosts=ghosts)
        rec = server.get_scene_serializer()
        record = _pose_recorder(server, rec)
        marks = list(enumerate(scene.marks))
        t0 = engines[0].trajectory.time[0]
        now = 0.0
        for k, t in enumerate(scene.times):
            if t > now:
                rec.insert_sleep(float(t - now))
                now = float(t)
            while marks and marks[0][1].time - t0 <= t + 1e-9:
                scene.add_mark(*marks.pop(0))
            if record is None:
                scene.show(k)
            else:
                record(scene, k)
        return str(rec.as_html())
    finally:
        _stop(server)


def _pose_recorder(server: Any, rec: Any) -> Any:
    """A fast way to record every node's pose at a frame: the pose messages written straight
    into the recording (the handles' setters also compare and broadcast each value, 10x the
    time); None where this viser has no such messages (the setters are used then)."""
    try:
        from viser import _messages

        owner = server.scene._owner_id
        position, orientation = _messages.SetPositionMessage, _messages.SetOrientationMessage
        update = _messages.SceneNodeUpdateMessage
        insert = rec._insert_message
    except (ImportError, AttributeError):
        return None

    def record(scene: _Scene, k: int) -> None:
        for n in scene.nodes:
            for msg in (
                position(n.handle.name, tuple(n.positions[k].tolist())),
                orientation(n.handle.name, tuple(n.wxyz[k].tolist())),
            ):
                msg.owner = owner
                insert(msg)
        for h, g in scene.ghosts:
            pts = np.ascontiguousarray(g[:, min(k, g.shape[1] - 1)].reshape(-1, 3), np.float32)
            insert(update(h.name, {"points": pts}, owner=owner))

    return record


def _stop(server: Any) -> None:
    """Stop ``server`` without its words on stdout (which carries simbridge's results)."""
    import contextlib
    import io

    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        server.stop()


def _quiet_server(host: str = "127.0.0.1", port: int = 8080) -> Any:
    import contextlib
    import io

    import viser

    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        return viser.ViserServer(host=host, port=port, verbose=False)


# ------------------------------------------------------------------ from a report folder


def engines_from_report(folder: str | Path) -> list[ReplayEngine]:
    """The engines of the report in ``folder``: its ``trajectories/<engine>.npz`` in
    ``summary.json``'s order, their events and the ghosts of :data:`GHOSTS_FILE` if there."""
    import json

    from simbridge.exceptions import InvalidArgumentError

    folder = Path(folder)
    summary = folder / "summary.json"
    if not summary.is_file():
        raise InvalidArgumentError(
            "report_dir",
            f"{str(folder)!r} is not a report folder (no summary.json; expected the folder "
            "`simbridge compare` wrote: summary.json and trajectories/<engine>.npz)",
        )
    data = json.loads(summary.read_text(encoding="utf-8"))
    labels = _labels_of(data)
    ghosts: dict[str, Any] = {}
    if (folder / GHOSTS_FILE).is_file():
        with np.load(folder / GHOSTS_FILE) as z:
            ghosts = {k: z[k] for k in z.files}
    out = []
    for slot, label in enumerate(labels):
        stem = file_stem(label)
        path = folder / "trajectories" / f"{stem}.npz"
        if not path.is_file():
            continue
        tr = Trajectory.load(path)
        g = ghosts.get(f"{stem}/points")
        rows = ghosts.get(f"{stem}/rows")
        out.append(
            ReplayEngine(label, _engine_colour(slot), tr, find_events(tr, label=label), g, rows)
        )
    if not out:
        raise InvalidArgumentError(
            "report_dir",
            f"{str(folder)!r} holds no trajectories/<engine>.npz (a report written with its "
            "trajectories is needed)",
        )
    return out


def _labels_of(summary: dict[str, Any]) -> list[str]:
    for key in ("labels", "engines"):
        v = summary.get(key)
        if isinstance(v, list) and v and all(isinstance(x, str) for x in v):
            return list(v)
        if isinstance(v, list) and v and all(isinstance(x, dict) for x in v):
            names = [x.get("label") or x.get("name") for x in v]
            if all(isinstance(n, str) for n in names):
                return list(names)
    files = summary.get("files", [])
    return [Path(f).stem for f in files if f.startswith("trajectories/") and f.endswith(".npz")]


def save_ghosts(engines: list[ReplayEngine], folder: str | Path) -> Path | None:
    """Write the engines' ghosts to ``folder/`` :data:`GHOSTS_FILE` (None when there are none)."""
    arrays = {}
    for eng in engines:
        if eng.ghosts is not None and eng.ghost_rows is not None:
            arrays[f"{_name(eng.label)}/points"] = eng.ghosts.astype(np.float32)
            arrays[f"{_name(eng.label)}/rows"] = eng.ghost_rows
    if not arrays:
        return None
    path = Path(folder) / GHOSTS_FILE
    with path.open("wb") as f:
        np.savez_compressed(f, **arrays)  # type: ignore[arg-type]
    return path


# ------------------------------------------------------------------ live


def serve(
    folder: str | Path,
    *,
    host: str = "127.0.0.1",
    port: int = 8080,
    ready: Any = None,
) -> None:
    """Serve the replay of the report in ``folder`` live until Ctrl-C (KeyboardInterrupt):
    a time slider, play and pause, speed, a checkbox per engine and a button per event in the
    viewer's panel. ``ready(url)`` is called once the server listens (default: print it)."""
    import time

    engines = engines_from_report(folder)
    server = _quiet_server(host, port)
    try:
        scene = _Scene(server, engines)
        for i, m in enumerate(scene.marks):
            scene.add_mark(i, m)
        gui = server.gui
        duration = float(scene.times[-1]) if len(scene.times) else 0.0
        slider = gui.add_slider(
            "time (s)", min=0.0, max=max(duration, 1e-6), step=1e-3, initial_value=0.0
        )
        playing = gui.add_checkbox("play", initial_value=True)
        speed = gui.add_dropdown("speed", ("0.25x", "0.5x", "1x", "2x", "4x"), initial_value="1x")
        for eng in engines:
            box = gui.add_checkbox(f"show {eng.label}", initial_value=True)

            @box.on_update
            def _(_: Any, box: Any = box, label: str = eng.label) -> None:
                for handle in scene.roots[label]:
                    handle.visible = bool(box.value)

        folder_events = gui.add_folder("events")
        with folder_events:
            for m in scene.marks:
                b = gui.add_button(f"{m.time:.3f} s {m.label}: {m.kind}"[:60])

                @b.on_click
                def _(_: Any, t: float = m.time) -> None:
                    playing.value = False
                    slider.value = t

        @slider.on_update
        def _(_: Any) -> None:
            k = int(np.clip(np.searchsorted(scene.times, slider.value), 0, len(scene.times) - 1))
            scene.show(k)

        url = f"http://{host}:{server.get_port()}"
        (ready or print)(url)
        last = time.monotonic()
        while True:
            time.sleep(1 / 30)
            now = time.monotonic()
            if playing.value and duration > 0:
                t = slider.value + (now - last) * float(speed.value.rstrip("x"))
                slider.value = t if t <= duration else 0.0
            last = now
    finally:
        _stop(server)
