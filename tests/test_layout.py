"""Tests, benchmarks and examples speak the `Sim` interface; a look inside a backend goes
through that backend's own door, from that backend's own test file.

Every file is parsed with :mod:`ast` (none is executed), so a rule holds wherever the code
stands: at the top, inside a function, or in a string given to ``getattr``.

- No file under tests/, bench/ or examples/ reaches into a `Sim`'s backend (``sim._b``): each
  backend package's inspect module (``simbridge.backends.<name>.inspect``, for example
  ``simbridge.backends.mujoco.inspect``) is its door.
- A test file imports a backend's modules only when it is that backend's own test file
  (a file under tests/backends/<name>/ for the package backends/<name>/: every package under
  backends/ is a backend and is covered alike, with no list to keep); bench/ may use the doors
  for its raw floors.
- The conformance suite (tests/conformance/) runs the same tests on every registered backend,
  a third-party one too: it speaks the public interface alone, with no private name of
  simbridge imported and no private attribute read.
- Tests mirror the packages: a test file sits in the folder of what it tests (tests/interface/
  for the modules at the top of src/simbridge, tests/<room>/ for each folder of it,
  tests/backends/<name>/, tests/compare/<stage>/ for each package or module of compare/),
  in tests/conformance/ or tests/hostile/, or at the top of tests/ when it checks the project
  as a whole; every room of the core and every stage of compare has its folder.
"""

from __future__ import annotations

import ast
from collections.abc import Iterator
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TESTS = ROOT / "tests"


def _backend_packages() -> tuple[str, ...]:
    """The backends this project ships: every package under backends/ (a folder with an
    ``__init__.py``), named as under simbridge.backends."""
    return tuple(sorted(p.parent.name for p in (ROOT / "backends").glob("*/__init__.py")))


def own_tests(backend: str) -> Path:
    """The folder of a backend package's own test files."""
    return TESTS / "backends" / backend


BACKENDS = _backend_packages()

# The public API of namedtuples (JointInfo and the other state records) starts with "_".
NAMEDTUPLE_API = {"_asdict", "_fields", "_replace", "_make", "_field_defaults"}


def _files(*folders: str) -> list[Path]:
    return sorted(p for folder in folders for p in (ROOT / folder).rglob("*.py"))


def _tree(path: Path) -> ast.Module:
    return ast.parse(path.read_text(encoding="utf-8"), filename=str(path))


def _backend_reaches(tree: ast.Module) -> Iterator[tuple[int, str]]:
    """(line, code) of every read of a backend attribute ``_b``: ``x._b`` or
    ``getattr(x, "_b")`` (also hasattr, setattr, delattr)."""
    for node in ast.walk(tree):
        attribute = isinstance(node, ast.Attribute) and node.attr == "_b"
        by_name = (
            isinstance(node, ast.Call)
            and isinstance(node.func, ast.Name)
            and node.func.id in {"getattr", "hasattr", "setattr", "delattr"}
            and len(node.args) >= 2
            and isinstance(node.args[1], ast.Constant)
            and node.args[1].value == "_b"
        )
        if attribute or by_name:
            yield node.lineno, ast.unparse(node)


def _imported_modules(tree: ast.Module) -> Iterator[tuple[int, str]]:
    """(line, dotted name) of every absolute import: ``import a.b`` gives a.b, ``from a import
    b`` gives a.b (b may be a module or a name in a: both are listed), ``importlib.import_module
    ("a.b")`` gives a.b."""
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield node.lineno, alias.name
        elif isinstance(node, ast.ImportFrom) and not node.level and node.module:
            for alias in node.names:
                yield node.lineno, f"{node.module}.{alias.name}"
        elif (
            isinstance(node, ast.Call)
            and isinstance(node.func, (ast.Name, ast.Attribute))
            and (node.func.id if isinstance(node.func, ast.Name) else node.func.attr)
            == "import_module"
            and node.args
            and isinstance(node.args[0], ast.Constant)
            and isinstance(node.args[0].value, str)
        ):
            yield node.lineno, node.args[0].value


def _backend_of_module(name: str, backends: tuple[str, ...] = BACKENDS) -> str | None:
    """Which backend package a module under simbridge.backends belongs to ("" for the
    simbridge.backends package itself or a module of no backend package; None: not a backend
    module)."""
    if name != "simbridge.backends" and not name.startswith("simbridge.backends."):
        return None
    first = name.removeprefix("simbridge.backends").lstrip(".").split(".")[0]
    return first if first in backends else ""


def _foreign_backend_imports(
    path: Path, tree: ast.Module, backends: tuple[str, ...] = BACKENDS
) -> Iterator[tuple[int, str]]:
    """Imports of a backend's modules in a test file that is not that backend's own."""
    for line, name in _imported_modules(tree):
        backend = _backend_of_module(name, backends)
        if backend is None:
            continue
        if not backend or not path.is_relative_to(own_tests(backend)):
            yield line, name


def _private_uses(
    tree: ast.Module, helpers: frozenset[str] = frozenset()
) -> Iterator[tuple[int, str]]:
    """Private names of simbridge imported, and private attributes read (dunders and the
    namedtuple API are public). Not counted: attributes of self or cls, and of the suite's own
    helper modules (``helpers``: the names of the .py files beside the test, such as
    ``_reference``), whose insides are the suite's own."""
    for line, name in _imported_modules(tree):
        parts = name.split(".")
        if parts[0] == "simbridge" and any(p.startswith("_") for p in parts[1:]):
            yield line, name
    own = {"self", "cls"}
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            own.update(a.asname or a.name for a in node.names if a.name in helpers)
    for node in ast.walk(tree):
        if (
            isinstance(node, ast.Attribute)
            and node.attr.startswith("_")
            and not (node.attr.startswith("__") and node.attr.endswith("__"))
            and node.attr not in NAMEDTUPLE_API
            and not (isinstance(node.value, ast.Name) and node.value.id in own)
        ):
            yield node.lineno, ast.unparse(node)


def _report(found: dict[Path, list[tuple[int, str]]]) -> str:
    return "\n".join(
        f"  {path.relative_to(ROOT)}:{line}: {code}"
        for path, hits in found.items()
        for line, code in hits
    )


def test_no_file_reaches_into_a_sims_backend():
    found = {
        path: hits
        for path in _files("tests", "bench", "examples")
        if (hits := list(_backend_reaches(_tree(path))))
    }
    assert not found, (
        "these read a Sim's backend (sim._b); use the public interface, or the backend's "
        "inspect module (simbridge.backends.<name>.inspect) from that backend's own test "
        "file (tests/backends/<name>/):\n" + _report(found)
    )


def test_backend_modules_are_imported_only_by_their_own_test_files():
    found = {
        path: hits
        for path in _files("tests")
        if (hits := list(_foreign_backend_imports(path, _tree(path))))
    }
    own = ", ".join(f"{own_tests(backend).relative_to(ROOT)}/" for backend in BACKENDS)
    assert not found, (
        f"a backend's modules are looked into only from its own test file ({own}); these "
        "should use the public interface (sim.manifest(), sim.profile, ...) or move there:\n"
        + _report(found)
    )


def test_conformance_suite_speaks_the_public_interface():
    suite = _files("tests/conformance")
    helpers = frozenset(path.stem for path in suite)
    found = {path: hits for path in suite if (hits := list(_private_uses(_tree(path), helpers)))}
    assert not found, (
        "the conformance suite runs on any backend through the public interface; move these "
        "checks to the backend's own test file or find a public way:\n" + _report(found)
    )


def test_every_backend_package_is_found():
    """The rules cover every package under backends/, the two the project has always shipped
    among them; a new one (backends/physx/) is covered by being there."""
    assert {"mujoco", "pybullet"} <= set(BACKENDS)
    assert not list((ROOT / "backends").glob("pybullet_*.py")), "PyBullet is a package now"


def test_the_rules_see_what_they_forbid():
    """Each rule flags a sample of what it forbids, in each way it can be written; a backend
    package the project does not ship yet (physx here) is held to the same rule."""
    code = ast.parse(
        "import simbridge.backends.mujoco.inspect\n"
        "def f(sim):\n"
        "    from simbridge.backends.pybullet.inspect import client_id\n"
        "    from simbridge.backends import mujoco\n"
        "    from simbridge import _version\n"
        "    importlib.import_module('simbridge.backends.pybullet.backend')\n"
        "    c = sim._b._c\n"
        "    return getattr(sim, '_b'), info._asdict(), self._x, x.__class__, ref._rule\n"
        "import simbridge.backends.physx.inspect\n"
    )
    assert sorted(line for line, _ in _backend_reaches(code)) == [7, 8]
    backends = ("mujoco", "physx", "pybullet")
    elsewhere = TESTS / "interface" / "test_core.py"
    assert [n for _, n in sorted(_foreign_backend_imports(elsewhere, code, backends))] == [
        "simbridge.backends.mujoco.inspect",
        "simbridge.backends.pybullet.inspect.client_id",
        "simbridge.backends.mujoco",
        "simbridge.backends.pybullet.backend",
        "simbridge.backends.physx.inspect",
    ]
    # in a backend's own test file, only the other backends' modules are flagged
    own = own_tests("mujoco") / "test_mujoco_backend.py"
    assert [n for _, n in sorted(_foreign_backend_imports(own, code, backends))] == [
        "simbridge.backends.pybullet.inspect.client_id",
        "simbridge.backends.pybullet.backend",
        "simbridge.backends.physx.inspect",
    ]
    own = own_tests("pybullet") / "test_pybullet_backend.py"
    assert [n for _, n in sorted(_foreign_backend_imports(own, code, backends))] == [
        "simbridge.backends.mujoco.inspect",
        "simbridge.backends.mujoco",
        "simbridge.backends.physx.inspect",
    ]
    own = own_tests("physx") / "test_physx_backend.py"
    assert [n for _, n in sorted(_foreign_backend_imports(own, code, backends))] == [
        "simbridge.backends.mujoco.inspect",
        "simbridge.backends.pybullet.inspect.client_id",
        "simbridge.backends.mujoco",
        "simbridge.backends.pybullet.backend",
    ]
    assert sorted(code for _, code in _private_uses(code)) == [
        "ref._rule",
        "sim._b",
        "sim._b._c",
        "simbridge._version",
    ]
    # the suite's own helper module, imported under any name, is the suite's own
    helper = ast.parse("import _reference as ref\n" + ast.unparse(code))
    assert sorted(code for _, code in _private_uses(helper, frozenset({"_reference"}))) == [
        "sim._b",
        "sim._b._c",
        "simbridge._version",
    ]


def _mirrors() -> dict[str, str]:
    """Each folder of tests/ that may hold test files (from the repository root), and what it
    tests: the project as a whole, the interface, each folder of the core, each backend, each
    stage of compare (a package or a module of compare/), every backend at once, the hostile
    corpus. Read from the tree, with no list to keep."""
    core, compare = ROOT / "src" / "simbridge", ROOT / "compare"
    folders = {
        "tests": "the project as a whole",
        "tests/interface": "src/simbridge/*.py",
        "tests/conformance": "every registered backend",
        "tests/hostile": "every reader and backend, fed hostile input",
    }
    for init in sorted(core.glob("*/__init__.py")):
        folders[f"tests/{init.parent.name}"] = f"src/simbridge/{init.parent.name}/"
    for backend in BACKENDS:
        folders[f"tests/backends/{backend}"] = f"backends/{backend}/"
    for init in sorted(compare.glob("*/__init__.py")):
        folders[f"tests/compare/{init.parent.name}"] = f"compare/{init.parent.name}/"
    for module in sorted(compare.glob("*.py")):
        # compare/errors.py: its errors pickle and warn by their old path beside every other
        # error of simbridge, in tests/interface/test_exceptions_pickle.py
        if module.stem not in ("__init__", "errors"):
            folders[f"tests/compare/{module.stem}"] = f"compare/{module.name}"
    return folders


def test_tests_mirror_the_packages():
    """A test file sits in the folder of what it tests, and every room of the core and every
    stage of compare has its tests (a new backend needs none of its own: tests/conformance/
    runs on it)."""
    mirrors = _mirrors()
    folders = {str(path.parent.relative_to(ROOT)) for path in TESTS.rglob("test_*.py")}
    stray = sorted(folders - set(mirrors))
    assert not stray, (
        f"these folders of tests/ mirror no package; a test file sits in one of {sorted(mirrors)}"
        f": {stray}"
    )
    rooms = [f for f, what in mirrors.items() if what.startswith(("src/simbridge/", "compare/"))]
    untested = sorted(f for f in rooms if f not in folders)
    assert not untested, f"no tests in {untested}"
    assert {"tests/model", "tests/sim", "tests/cli", "tests/compare/run"} <= set(rooms)


def test_the_modules_scheduled_first_exist():
    """tests/conftest.py hands its long modules out first under --dist loadfile: a module
    renamed or moved would silently fall back to xdist's order (long modules last)."""
    import importlib.util

    root = Path(__file__).resolve().parents[1]
    spec = importlib.util.spec_from_file_location("_top_conftest", root / "tests" / "conftest.py")
    assert spec is not None and spec.loader is not None
    top = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(top)  # tests/conftest.py by path: another folder's is "conftest"
    SCHEDULED_FIRST = top.SCHEDULED_FIRST
    assert [m for m in SCHEDULED_FIRST if not (root / m).is_file()] == []
    assert len(set(SCHEDULED_FIRST)) == len(SCHEDULED_FIRST)
