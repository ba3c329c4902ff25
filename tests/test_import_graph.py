"""No import circle inside the installed ``simbridge`` package (core, backends, compare).

Every module of the package is parsed with :mod:`ast` (none is executed) and every ``import``
statement in it becomes an edge to the simbridge module it names, wherever the statement
stands: at the top, inside a function (a lazy import), or under ``if TYPE_CHECKING:``. A lazy
or type-checking import does not fail at run time, but it still ties the two modules together,
so a module that imports another that imports it back is a circle however either import is
written.

``from package import name`` is an edge to ``package.name`` when that is a module; else to
``package`` itself when its ``__init__`` binds ``name`` (a compiled submodule, such as the
MuJoCo step loop, is no edge: it imports nothing of simbridge). Importing ``a.b.c`` also runs
``a`` and ``a.b`` first; those implicit parent-package imports are not edges (a package's
``__init__`` importing its own submodules is the ordinary layout, not a circle).
"""

from __future__ import annotations

import ast
import importlib.util
import pkgutil
import tomllib
from importlib.machinery import ModuleSpec
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _declared_packages() -> list[str]:
    """The packages mapped to folders (pyproject.toml's [tool.setuptools] package-dir; setup.py
    installs every package below each): an editable install maps simbridge.backends and
    simbridge.compare from their own folders, so walking simbridge's own folder would not find
    them. The walk below goes down into each one's subpackages."""
    data = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    return list(data["tool"]["setuptools"]["package-dir"])


def _modules() -> dict[str, tuple[Path, bool]]:
    """Module name -> (source file, is a package), as the installed package resolves them.
    Only the declared packages' parents are imported to find them (simbridge, its backends
    and compare folders); no module below them runs."""
    found: dict[str, tuple[Path, bool]] = {}

    def walk(name: str, spec: ModuleSpec) -> None:
        if spec.origin and spec.origin.endswith(".py"):
            found[name] = (Path(spec.origin), spec.submodule_search_locations is not None)
        for info in pkgutil.iter_modules(spec.submodule_search_locations or []):
            full = f"{name}.{info.name}"
            sub = info.module_finder.find_spec(full, None)
            if sub is not None:
                walk(full, sub)

    for package in _declared_packages():
        if package == "simbridge" or package.startswith("simbridge."):
            spec = importlib.util.find_spec(package)
            assert spec is not None, f"{package} is declared in pyproject.toml but not found"
            walk(package, spec)
    return found


def _top_level_names(tree: ast.Module) -> set[str] | None:
    """The names a module binds outside functions and classes (None after ``import *``: any)."""
    names: set[str] = set()
    body: list[ast.stmt] = list(tree.body)
    while body:
        node = body.pop()
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.add(node.name)
        elif isinstance(node, (ast.Import, ast.ImportFrom)):
            for alias in node.names:
                if alias.name == "*":
                    return None
                names.add(alias.asname or alias.name.split(".")[0])
        elif isinstance(node, (ast.Assign, ast.AnnAssign, ast.AugAssign)):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            for target in targets:
                names.update(n.id for n in ast.walk(target) if isinstance(n, ast.Name))
        for field in ("body", "orelse", "finalbody", "handlers"):
            if not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                body.extend(getattr(node, field, []))
    return names


def _edges(modules: dict[str, tuple[Path, bool]]) -> dict[str, dict[str, int]]:
    """module -> {imported simbridge module: line of the first import statement}."""
    trees = {
        name: ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
        for name, (path, _) in modules.items()
    }
    bound = {name: _top_level_names(trees[name]) for name, (_, pkg) in modules.items() if pkg}
    graph: dict[str, dict[str, int]] = {}
    for name, (_, is_package) in modules.items():
        out: dict[str, int] = {}
        package = name if is_package else name.rpartition(".")[0]
        for node in ast.walk(trees[name]):
            targets: list[str] = []
            if isinstance(node, ast.Import):
                for alias in node.names:
                    # "import a.b.c" binds a, runs a.b.c: the deepest simbridge module named
                    parts = alias.name.split(".")
                    for k in range(len(parts), 0, -1):
                        if ".".join(parts[:k]) in modules:
                            targets.append(".".join(parts[:k]))
                            break
            elif isinstance(node, ast.ImportFrom):
                if node.level:
                    base = package.split(".")
                    base = base[: len(base) - (node.level - 1)]
                    origin = ".".join(base + ([node.module] if node.module else []))
                else:
                    origin = node.module or ""
                for alias in node.names:
                    sub = f"{origin}.{alias.name}"
                    if sub in modules:
                        targets.append(sub)
                    elif origin in modules:
                        names = bound.get(origin)  # a plain module: any name is its own
                        if origin not in bound or names is None or alias.name in names:
                            targets.append(origin)
                    # else: a submodule that is not Python source (the compiled step loop,
                    # built or not): no edge to the package that would only hold it
            for target in targets:
                if target != name:  # a package reading its own attribute is no circle
                    out.setdefault(target, node.lineno)
        graph[name] = out
    return graph


def _cycles(graph: dict[str, dict[str, int]]) -> list[list[str]]:
    """One shortest circle through each strongly connected component of more than one module
    (Tarjan's algorithm), starting at the component's first module by name."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    components: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph.get(v, {}):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                components.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)

    circles = []
    for component in components:
        members = set(component)
        start = component[0]
        # breadth-first from start back to start inside the component: the shortest circle
        previous: dict[str, str] = {}
        queue = [start]
        end = None
        while queue and end is None:
            v = queue.pop(0)
            for w in sorted(graph[v]):
                if w not in members:
                    continue
                if w == start:
                    end = v
                    break
                if w not in previous:
                    previous[w] = v
                    queue.append(w)
        path = [start]
        v = end
        while v is not None and v != start:
            path.append(v)
            v = previous[v]
        circles.append([start, *reversed(path[1:]), start])
    return circles


def _describe(graph: dict[str, dict[str, int]], circle: list[str]) -> str:
    steps = [f"{a} (line {graph[a][b]}) -> {b}" for a, b in zip(circle, circle[1:], strict=False)]
    return "; ".join(steps)


def test_every_package_module_is_found():
    modules = _modules()
    for name in (
        "simbridge",
        "simbridge.sim",
        "simbridge.model.urdf",
        "simbridge.backends.pybullet.backend",
        "simbridge.compare.scenario",
    ):
        assert name in modules
    assert any(name.startswith("simbridge.backends.mujoco") for name in modules)
    # every package under backends/ is declared, so the rules below see it installed
    on_disk = {p.parent.name for p in (ROOT / "backends").glob("*/__init__.py")}
    assert on_disk == set(_backend_packages(modules))


def test_the_import_graph_has_no_circle():
    graph = _edges(_modules())
    circles = _cycles(graph)
    assert not circles, "import circles:\n" + "\n".join(_describe(graph, c) for c in circles)


@pytest.mark.parametrize(
    "sources, circle",
    [
        (
            {
                "pkg": "from . import a\n",
                "pkg.a": "import typing\nif typing.TYPE_CHECKING:\n    from .b import X\n",
                "pkg.b": "def f():\n    from pkg.a import Y\n",
            },
            ["pkg.a", "pkg.b", "pkg.a"],
        ),
        ({"pkg": "from . import a\n", "pkg.a": "import pkg\n"}, ["pkg", "pkg.a", "pkg"]),
        (
            {"pkg": "", "pkg.a": "from pkg import b\n", "pkg.b": "from .a import c\n"},
            ["pkg.a", "pkg.b", "pkg.a"],
        ),
        ({"pkg": "", "pkg.a": "from pkg import b\n", "pkg.b": "x = 1\n"}, []),
        (
            {"pkg": "from .a import f\nV = 1\n", "pkg.a": "def f():\n    from . import V\n"},
            ["pkg", "pkg.a", "pkg"],
        ),
        ({"pkg": "from .a import f\n", "pkg.a": "def f():\n    from . import _compiled\n"}, []),
    ],
)
def test_the_checker_sees_lazy_and_type_checking_circles(tmp_path, sources, circle):
    """The checker itself: a circle through a TYPE_CHECKING import and a lazy import is found,
    so is one through a package's __init__ (a name it binds); a plain chain is not a circle,
    nor is a package's import of a compiled submodule."""
    modules = {}
    for name, text in sources.items():
        path = tmp_path / f"{name}.py"
        path.write_text(text, encoding="utf-8")
        modules[name] = (path, name == "pkg")
    graph = _edges(modules)
    circles = _cycles(graph)
    assert circles == ([circle] if circle else [])


# ---------------------------------------------------------------- compare/'s stages

STAGES = ("errors", "scenario", "run", "analysis", "pipeline", "report", "study")
"""simbridge.compare's stages, in pipeline order: a module imports only modules of its own stage
and of the stages before it (the package itself, above them all, imports any). ``errors``
(compare's error classes) is below every stage. ``study`` (sets of comparisons: resolve, sweep,
explain) comes last: it runs the pipeline and words its own reports."""


def _stage(module: str) -> int | None:
    """The index of ``module``'s stage in :data:`STAGES`; None for simbridge.compare itself."""
    parts = module.split(".")
    if parts[:2] != ["simbridge", "compare"]:
        raise ValueError(module)
    if len(parts) == 2:
        return None
    return STAGES.index(parts[2]) if parts[2] in STAGES else -1


def _stage_breaches(graph: dict[str, dict[str, int]]) -> list[str]:
    out = []
    for module, targets in sorted(graph.items()):
        if not module.startswith("simbridge.compare."):
            continue
        own = _stage(module)
        if own == -1:
            out.append(f"{module} is in no stage of {STAGES}")
            continue
        for target, line in targets.items():
            if not (target == "simbridge.compare" or target.startswith("simbridge.compare.")):
                continue
            theirs = _stage(target)
            if theirs is None or (own is not None and theirs is not None and theirs > own):
                where = "the package" if theirs is None else STAGES[theirs]
                out.append(
                    f"{module} (stage {STAGES[own]}, line {line}) imports {target} ({where})"
                )
    return out


def test_compare_stages_import_only_the_stages_before_them():
    """errors < scenario < run < analysis < pipeline < report < study: each stage of
    simbridge.compare imports only its own stage and those before it, never the package's
    __init__ (which imports every stage), and every module of compare/ is in a stage."""
    modules = _modules()
    assert {f"simbridge.compare.{s}" for s in STAGES} <= set(modules)
    breaches = _stage_breaches(_edges(modules))
    assert not breaches, "\n".join(breaches)


def test_the_stage_checker_sees_a_backward_import():
    graph = {
        "simbridge.compare.run.ensemble": {"simbridge.compare.analysis.verdict": 3},
        "simbridge.compare.analysis.verdict": {"simbridge.compare.run.quantities": 5},
        "simbridge.compare.report.fmt": {"simbridge.compare": 7},
        "simbridge.compare.extra": {},
    }
    assert _stage_breaches(graph) == [
        "simbridge.compare.extra is in no stage of "
        "('errors', 'scenario', 'run', 'analysis', 'pipeline', 'report', 'study')",
        "simbridge.compare.report.fmt (stage report, line 7) imports simbridge.compare "
        "(the package)",
        "simbridge.compare.run.ensemble (stage run, line 3) imports "
        "simbridge.compare.analysis.verdict (analysis)",
    ]


def _formatted_strings(tree: ast.Module) -> list[int]:
    """Lines of the f-strings of a module that are not in an exception raised, a warning or a
    log record: text built from figures, which is the report stage's to write."""
    allowed: set[int] = set()
    for node in ast.walk(tree):
        carrier = isinstance(node, ast.Raise)
        if isinstance(node, ast.Call):
            f = node.func
            name = f.attr if isinstance(f, ast.Attribute) else getattr(f, "id", "")
            carrier = name in {"warn", "debug", "info", "warning", "error", "exception"} or (
                name.endswith("Error") or name.endswith("Exception")
            )
        if carrier:
            allowed.update(id(n) for n in ast.walk(node))
    return [
        n.lineno for n in ast.walk(tree) if isinstance(n, ast.JoinedStr) and id(n) not in allowed
    ]


def test_the_analysis_stage_writes_no_sentence():
    """No module of compare/analysis/ formats a string from its figures (an error message
    aside): what it finds goes out as typed results, and the report stage words them."""
    found = []
    for name, (path, _) in sorted(_modules().items()):
        if name.startswith("simbridge.compare.analysis"):
            tree = ast.parse(path.read_text(encoding="utf-8"))
            found += [f"{path.name}:{line}" for line in _formatted_strings(tree)]
    assert not found, "formatted strings in the analysis stage: " + ", ".join(found)


# ---------------------------------------------------------------- the backend packages


def _backend_packages(modules: dict[str, tuple[Path, bool]]) -> list[str]:
    """The backend packages installed: every package directly under simbridge.backends
    (``simbridge.backends.<name>``), the shipped ones and any added beside them alike."""
    return sorted(
        name.rpartition(".")[2]
        for name, (_, is_package) in modules.items()
        if is_package and name.rpartition(".")[0] == "simbridge.backends"
    )


def _engines(packages: list[str]) -> dict[str, set[str]]:
    """Backend package -> the engine modules it may import: what the registry entries whose
    class lives in that package require (``register(..., requires=("pybullet",))``)."""
    from simbridge.registry import available_backends, backend_spec

    engines: dict[str, set[str]] = {package: set() for package in packages}
    for name in available_backends():
        module = backend_spec(name).entry_point.partition(":")[0]
        parts = module.split(".")
        if parts[:2] == ["simbridge", "backends"] and len(parts) > 2 and parts[2] in engines:
            engines[parts[2]].update(backend_spec(name).requires)
    return engines


def _engine_imports(tree: ast.Module) -> list[tuple[int, str]]:
    """(line, top-level module) of every absolute import of a module outside simbridge."""
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out += [(node.lineno, a.name.split(".")[0]) for a in node.names]
        elif isinstance(node, ast.ImportFrom) and not node.level and node.module:
            out.append((node.lineno, node.module.split(".")[0]))
    return [(line, top) for line, top in out if top != "simbridge"]


# Core modules allowed an engine, each with its reason. simbridge.model.mjcf_native reads an MJCF
# file with MuJoCo's own compiler (load_mjcf(..., semantics="mujoco"): the model as MuJoCo
# compiles it is the truth there, and mujoco is a core dependency); the Sim imports it only for
# that reading, so `import simbridge` still loads no engine. mjcf_native_plan turns that compiled
# model into the build plans PyBullet and PhysX build, and mjcf_mirror evaluates MuJoCo's own
# actuator, spring and damping formulas and reads on their state (the same reading on every
# engine); the backends that run that reading import them, nothing else does.
ENGINE_READERS = {
    "simbridge.model.mjcf_native": {"mujoco"},
    "simbridge.model.mjcf_native_plan": {"mujoco"},
    "simbridge.model.mjcf_mirror": {"mujoco"},
}


def _layer_breaches(
    modules: dict[str, tuple[Path, bool]], engines: dict[str, set[str]]
) -> list[str]:
    """Each backend package imports its own modules, the modules shared by every backend
    (simbridge.backends' own plain modules, such as ``locking``), the core and its own engine;
    never another backend package, compare, or another backend's engine. Nothing outside the
    backend packages imports an engine."""
    every_engine = set().union(*engines.values())
    graph = _edges(modules)
    out = []
    for module, (path, _) in sorted(modules.items()):
        parts = module.split(".")
        package = (
            parts[2]
            if parts[:2] == ["simbridge", "backends"] and len(parts) > 2 and parts[2] in engines
            else None
        )
        own_engine = engines.get(package, set()) if package else ENGINE_READERS.get(module, set())
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for line, top in _engine_imports(tree):
            if top in every_engine and top not in own_engine:
                out.append(f"{module} (line {line}) imports the engine {top}")
        if package is None:
            continue
        for target, line in graph[module].items():
            t = target.split(".")
            own = t[:3] == ["simbridge", "backends", package]
            shared = t[:2] == ["simbridge", "backends"] and (
                len(t) == 2 or (len(t) == 3 and not modules[target][1])
            )
            core = t[1] not in ("backends", "compare") if len(t) > 1 else True
            if not (own or shared or core):
                out.append(f"{module} (line {line}) imports {target}")
    return out


def test_each_backend_package_imports_only_its_engine_the_interface_and_the_core():
    """backends/<name>/ imports its own modules, simbridge's core (the Backend interface, the
    types, the readers) and the engine its registry entry requires; every backend package is
    covered, a new one as soon as it is there and registered."""
    modules = _modules()
    packages = _backend_packages(modules)
    engines = _engines(packages)
    unregistered = [p for p, engine in engines.items() if not engine]
    assert not unregistered, (
        f"backend packages with no registry entry naming an engine: {unregistered}"
    )
    breaches = _layer_breaches(modules, engines)
    assert not breaches, "\n".join(breaches)


def test_the_backend_rule_sees_a_foreign_import(tmp_path):
    """The checker itself, on a made-up tree with a third backend package: a backend importing
    another backend's module, compare, or another's engine is flagged; the core importing an
    engine is flagged; a backend's own engine, the shared modules and the core are not."""
    sources = {
        "simbridge": ("", True),
        "simbridge.backend": ("import numpy\n", False),
        "simbridge.backends": ("", True),
        "simbridge.backends.locking": ("", False),
        "simbridge.backends.alpha": ("from .world import W\n", True),
        "simbridge.backends.alpha.world": (
            "import sapien\nfrom ..locking import x\nfrom simbridge.backend import Backend\n"
            "from simbridge.backends.beta import world\nimport mujoco\n",
            False,
        ),
        "simbridge.backends.beta": ("", True),
        "simbridge.backends.beta.world": (
            "import mujoco.viewer\nimport simbridge.compare\n",
            False,
        ),
        "simbridge.compare": ("import sapien\n", True),
    }
    modules = {}
    for name, (text, is_package) in sources.items():
        path = tmp_path / f"{name}.py"
        path.write_text(text, encoding="utf-8")
        modules[name] = (path, is_package)
    engines = {"alpha": {"sapien"}, "beta": {"mujoco"}}
    assert _backend_packages(modules) == ["alpha", "beta"]
    assert _layer_breaches(modules, engines) == [
        "simbridge.backends.alpha.world (line 5) imports the engine mujoco",
        "simbridge.backends.alpha.world (line 4) imports simbridge.backends.beta.world",
        "simbridge.backends.beta.world (line 2) imports simbridge.compare",
        "simbridge.compare (line 1) imports the engine sapien",
    ]


# ---------------------------------------------------------------- the core's floors

FLOORS = {"interface": 0, "model": 0, "sim": 1, "envs": 2, "cli": 3}
"""The core's rooms and their floors: the interface (simbridge's own plain modules: the Backend
contract, types, exceptions, profiles, registry, settings, transforms...) and ``model/`` (files
read into build plans, whose types the Backend contract names) at the bottom, then ``sim/`` (the
`Sim` and its parts), then ``envs/`` (Gymnasium environments over the Sim), then ``cli/``. A
module imports its own floor and the floors below it. The package's doors
(``simbridge/__init__``, re-exporting the `Sim`, and ``__main__``) stand above sim/: only cli/
may import them."""


def _floor(module: str) -> int | None:
    """A core module's floor (:data:`FLOORS`); None for the doors, the backends and compare."""
    parts = module.split(".")
    if (
        len(parts) == 1
        or parts[0] != "simbridge"
        or parts[1] in ("backends", "compare", "__main__")
    ):
        return None
    return FLOORS.get(parts[1], 0)


def _floor_breaches(graph: dict[str, dict[str, int]]) -> list[str]:
    """Every edge of the core that goes up a floor or to the package's door, every backend edge
    to sim/ or cli/, and every compare edge to cli/ or into a backend."""
    out = []
    for module, targets in sorted(graph.items()):
        own = _floor(module)
        parts = module.split(".")
        for target, line in targets.items():
            theirs = _floor(target)
            where = f"{module} (line {line}) imports {target}"
            if own is not None:
                door = target == "simbridge" and own < FLOORS["cli"]
                if door or (theirs is not None and theirs > own):
                    out.append(where)
            elif parts[1:2] == ["backends"] and theirs is not None and theirs >= FLOORS["sim"]:
                out.append(f"{where}: a backend takes the interface and the model alone")
            elif parts[1:2] == ["compare"] and (
                theirs == FLOORS["cli"] or target.startswith("simbridge.backends")
            ):
                out.append(f"{where}: compare speaks the interface")
    return out


def test_the_core_s_floors_import_only_downwards():
    """interface and model < sim < cli: model/ imports nothing of sim/ or cli/, sim/ nothing of
    cli/, neither the package's door; no backend imports sim/ or cli/ (the Sim drives backends,
    not the other way round); compare/ imports no backend and no cli module."""
    breaches = _floor_breaches(_edges(_modules()))
    assert not breaches, "\n".join(breaches)


def test_the_floor_checker_sees_an_upward_import():
    """The checker on made-up edges: model -> sim, interface -> sim, a backend -> sim and
    compare -> cli are flagged; sim -> model, cli -> sim and a backend -> model are not."""
    graph = {
        "simbridge.model.urdf": {"simbridge.sim.core": 3, "simbridge.types": 4},
        "simbridge.registry": {"simbridge.sim.core": 5, "simbridge.model.urdf": 5},
        "simbridge.sim.core": {"simbridge.model.urdf": 6, "simbridge.backend": 7},
        "simbridge.cli.main": {"simbridge.sim.core": 8, "simbridge.compare": 9},
        "simbridge.backends.alpha.model": {"simbridge.sim.lookups": 10, "simbridge.model.x": 11},
        "simbridge.compare.pipeline": {"simbridge.cli.main": 12, "simbridge.types": 13},
    }
    breaches = _floor_breaches(graph)
    assert [b.split(" ")[0] for b in breaches] == [
        "simbridge.backends.alpha.model",
        "simbridge.compare.pipeline",
        "simbridge.model.urdf",
        "simbridge.registry",
    ], breaches


def test_a_moved_module_s_old_name_still_imports_with_a_warning():
    """Each module that moved into a room imports by its old name for one release: the same
    module object, with a DeprecationWarning naming the new path."""
    import importlib
    import sys
    import warnings

    from simbridge._moved import MOVED

    for old, new in MOVED.items():
        sys.modules.pop(f"simbridge.{old}", None)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            module = importlib.import_module(f"simbridge.{old}")
        assert module is importlib.import_module(f"simbridge.{new}")
        messages = [str(w.message) for w in caught if w.category is DeprecationWarning]
        assert messages == [
            f"simbridge.{old} moved to simbridge.{new}; the old name goes in the next release"
        ], (old, messages)
        sys.modules.pop(f"simbridge.{old}", None)
