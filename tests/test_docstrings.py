"""Every public function of the core and the backends says its arguments, what it returns and
what it raises.

The docstrings follow the Google style (``Args:``, ``Returns:`` or ``Yields:``, ``Raises:``),
which the documentation can render. Files are parsed with :mod:`ast`; nothing is imported or
executed. The rule covers the folders and modules in ``SCOPE`` (add a folder there when its
docstrings are done).

What the rule asks of each public function and method (a name without a leading ``_``, defined
at module level or in a public class at module level, in a module whose name has no leading
``_``):

- it has a docstring;
- when it takes parameters beyond ``self``/``cls`` (``*args`` and ``**kwargs`` count by their
  names), its docstring has an ``Args:`` section naming each of them (``name:`` or
  ``name (type):`` at the start of a line, or in a group sharing one description:
  ``body, joints: as Sim.x's``; ``*args``/``**kwargs`` with or without stars);
- when its return annotation is not ``None`` (and it has one), ``Returns:`` or ``Yields:``;
- when its own body (not a nested function or class) has a ``raise`` with an exception, ``Raises:``
  (a bare ``raise`` re-raising is not counted, nor ``raise AssertionError(...)`` on a line that
  cannot run). An error raised by a function it calls is not required, though the docstring
  should say it where a caller would handle it.

A public class says its constructor's arguments: when it defines ``__init__`` with parameters,
the class docstring or ``__init__``'s names each of them under ``Args:``. A ``NamedTuple``
record documents each field: a docstring right after it, or its name under the class's
``Args:`` or ``Attributes:``.

The backends (``backends/``) are covered by the same rule. A backend class is composed of parts
(``StateReads``, ``MotorCommands``, ``ContactReads``, ``Snapshots``... in each engine's package):
each is a public class at module level, so its public methods are covered like the backend
class's own. A method that implements a method of the ``Backend`` contract
(src/simbridge/backend.py, where its Args/Returns/Raises are written) and behaves as the contract
says starts its docstring ``"See Backend.x."`` and adds a line on what its engine does
differently. A class or module whose name starts with ``_`` (PyBullet's per-body record
``_Body``, MuJoCo's snapshot record ``_Native``, the compiled ``_mjkernel``) is private, as in
the core.

``python tests/test_docstrings.py`` prints how many public functions and methods comply.

Exempt, and why:

- dunder methods (``__init__`` is covered through its class, above): their meaning is Python's;
- properties (``@property`` and its ``.setter``): a getter reads as an attribute, its docstring
  says what the value is;
- ``@overload`` stubs: the implementation carries the docstring;
- a trivial override whose docstring starts with ``See `` (``"See Backend.step."``): it points
  at the one place the contract is written;
- functions nested in functions: not public.
"""

from __future__ import annotations

import ast
import re
from collections.abc import Iterator
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CORE = ROOT / "src" / "simbridge"

# Folders (every module under them) and single modules the rule covers.
SCOPE: tuple[Path, ...] = (
    CORE / "backend.py",
    CORE / "bound.py",
    CORE / "exceptions.py",
    CORE / "types.py",
    CORE / "profiles.py",
    CORE / "registry.py",
    CORE / "engine_settings.py",
    CORE / "engine_output.py",
    CORE / "transforms.py",
    CORE / "terminate.py",
    CORE / "spherical.py",
    CORE / "model",
    CORE / "cli",
    CORE / "sim",
    CORE / "envs",
    ROOT / "backends",
)

_SECTION = re.compile(r"^\s*(Args|Arguments|Attributes|Returns|Yields|Raises):\s*$", re.MULTILINE)


def _files(scope: tuple[Path, ...] = SCOPE) -> list[Path]:
    files: set[Path] = set()
    for entry in scope:
        files.update(entry.rglob("*.py") if entry.is_dir() else [entry])
    return sorted(p for p in files if not p.name.startswith("_") or p.name == "__init__.py")


def _sections(doc: str) -> dict[str, str]:
    """The text of each Google-style section of ``doc``, by its title (Arguments as Args)."""
    found: dict[str, str] = {}
    marks = list(_SECTION.finditer(doc))
    for i, mark in enumerate(marks):
        end = marks[i + 1].start() if i + 1 < len(marks) else len(doc)
        title = "Args" if mark.group(1) == "Arguments" else mark.group(1)
        found[title] = doc[mark.end() : end]
    return found


def _names(function: ast.FunctionDef | ast.AsyncFunctionDef) -> list[str]:
    """The parameters a caller gives: all but a method's leading ``self``/``cls``."""
    a = function.args
    names = [p.arg for p in (*a.posonlyargs, *a.args, *a.kwonlyargs)]
    if a.vararg:
        names.append(a.vararg.arg)
    if a.kwarg:
        names.append(a.kwarg.arg)
    if names and names[0] in ("self", "cls"):
        names = names[1:]
    return names


def _documents(args_text: str, name: str) -> bool:
    """Whether ``Args:`` names ``name`` at the start of an entry: ``name:``, ``name (type):``, or
    in a group of parameters that share one description (``body, joints: as Sim.x's``)."""
    one = rf"\**{re.escape(name)}\s*(\([^)]*\))?"
    other = r"\**\w+"
    pattern = rf"^\s*(?:{other}\s*,\s*)*{one}\s*(?:,\s*{other}\s*)*:"
    return re.search(pattern, args_text, re.MULTILINE) is not None


def _invariant(exc: ast.expr) -> bool:
    """``AssertionError(...)``: a line that cannot run, not an error a caller handles."""
    target = exc.func if isinstance(exc, ast.Call) else exc
    return isinstance(target, ast.Name) and target.id == "AssertionError"


def _own_raises(function: ast.AST) -> bool:
    """Whether the body raises an exception itself (nested functions and classes not counted)."""
    stack = list(ast.iter_child_nodes(function))
    while stack:
        node = stack.pop()
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef | ast.Lambda):
            continue
        if isinstance(node, ast.Raise) and node.exc is not None and not _invariant(node.exc):
            return True
        stack.extend(ast.iter_child_nodes(node))
    return False


def _decorators(function: ast.FunctionDef | ast.AsyncFunctionDef) -> set[str]:
    names = set()
    for d in function.decorator_list:
        target = d.func if isinstance(d, ast.Call) else d
        if isinstance(target, ast.Name):
            names.add(target.id)
        elif isinstance(target, ast.Attribute):
            names.add(target.attr)
    return names


def _returns_value(function: ast.FunctionDef | ast.AsyncFunctionDef) -> bool:
    r = function.returns
    if r is None:
        return False
    return not (isinstance(r, ast.Constant) and r.value in (None, "None"))


def function_gaps(
    function: ast.FunctionDef | ast.AsyncFunctionDef, *, params: list[str] | None = None
) -> list[str]:
    """What the docstring of ``function`` lacks under the rule (empty when it complies).

    Args:
        function: The parsed function.
        params: The parameters to name under ``Args:``; by default the function's own.

    Returns:
        One line per gap: a missing docstring, section or argument.
    """
    doc = ast.get_docstring(function)
    if not doc:
        return ["no docstring"]
    if doc.lstrip().startswith("See "):
        return []
    sections = _sections(doc)
    gaps = []
    names = _names(function) if params is None else params
    if names:
        if "Args" not in sections:
            gaps.append("no Args: section")
        else:
            gaps += [f"Args: lacks {n}" for n in names if not _documents(sections["Args"], n)]
    if params is None and _returns_value(function):
        if "Returns" not in sections and "Yields" not in sections:
            gaps.append("no Returns: section")
    if _own_raises(function) and "Raises" not in sections:
        gaps.append("no Raises: section")
    return gaps


def _public_functions(
    tree: ast.Module,
) -> Iterator[tuple[str, ast.FunctionDef | ast.AsyncFunctionDef]]:
    for node in tree.body:
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            if not node.name.startswith("_"):
                yield node.name, node
        elif isinstance(node, ast.ClassDef) and not node.name.startswith("_"):
            for item in node.body:
                if isinstance(item, ast.FunctionDef | ast.AsyncFunctionDef):
                    if not item.name.startswith("_"):
                        yield f"{node.name}.{item.name}", item


def _exempt(function: ast.FunctionDef | ast.AsyncFunctionDef) -> bool:
    return bool(_decorators(function) & {"property", "setter", "deleter", "overload"})


def _constructor_gaps(cls: ast.ClassDef) -> list[str]:
    """What a public class lacks in saying its ``__init__``'s arguments."""
    init = next(
        (n for n in cls.body if isinstance(n, ast.FunctionDef) and n.name == "__init__"), None
    )
    if init is None or not _names(init):
        return []
    names = _names(init)
    texts = [ast.get_docstring(cls) or "", ast.get_docstring(init) or ""]
    args = "".join(_sections(t).get("Args", "") for t in texts)
    if not args:
        return ["constructor: no Args: section"]
    return [f"constructor: Args: lacks {n}" for n in names if not _documents(args, n)]


def _field_gaps(cls: ast.ClassDef) -> list[str]:
    """The fields of a NamedTuple record that nothing documents: each needs a docstring of its
    own (a string right after it) or its name under the class's ``Args:`` or ``Attributes:``."""
    if not any(isinstance(b, ast.Name) and b.id == "NamedTuple" for b in cls.bases):
        return []
    doc = ast.get_docstring(cls) or ""
    named = re.findall(
        r"^\s*(\w+)\s*(?:\([^)]*\))?\s*:",
        "".join(text for title, text in _sections(doc).items() if title in ("Args", "Attributes")),
        re.MULTILINE,
    )
    gaps = []
    for i, node in enumerate(cls.body):
        if not (isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name)):
            continue
        after = cls.body[i + 1] if i + 1 < len(cls.body) else None
        has_doc = (
            isinstance(after, ast.Expr)
            and isinstance(after.value, ast.Constant)
            and isinstance(after.value.value, str)
        )
        if not has_doc and node.target.id not in named:
            gaps.append(f"field {node.target.id} undocumented")
    return gaps


def source_gaps(source: str) -> list[str]:
    """Every gap in one module's source, as ``name: gap``.

    Args:
        source: Python source text.

    Returns:
        One line per gap, in the order of the source.
    """
    tree = ast.parse(source)
    gaps = []
    for name, function in _public_functions(tree):
        if not _exempt(function):
            gaps += [f"{name} (line {function.lineno}): {g}" for g in function_gaps(function)]
    for node in tree.body:
        if isinstance(node, ast.ClassDef) and not node.name.startswith("_"):
            gaps += [f"{node.name} (line {node.lineno}): {g}" for g in _constructor_gaps(node)]
            gaps += [f"{node.name} (line {node.lineno}): {g}" for g in _field_gaps(node)]
    return gaps


def count(scope: tuple[Path, ...] = SCOPE) -> tuple[int, int]:
    """(public functions and methods that comply, all of them) over ``scope``.

    Args:
        scope: Folders and modules to count.

    Returns:
        The two counts.
    """
    good = total = 0
    for path in _files(scope):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for _, function in _public_functions(tree):
            if not _exempt(function):
                total += 1
                good += not function_gaps(function)
    return good, total


def test_scope_exists() -> None:
    missing = [str(p.relative_to(ROOT)) for p in SCOPE if not p.exists()]
    assert not missing, f"SCOPE names what is not there: {missing}"


def test_public_functions_say_args_returns_raises() -> None:
    gaps = [
        f"{path.relative_to(ROOT)}: {gap}"
        for path in _files()
        for gap in source_gaps(path.read_text(encoding="utf-8"))
    ]
    assert not gaps, f"{len(gaps)} docstring gaps:\n" + "\n".join(gaps)


MADE_UP = '''
def no_doc(x): pass

def missing_arg(x: int, *, y: int = 0) -> int:
    """Adds.

    Args:
        x: A number.

    Returns:
        The sum.
    """
    return x + y

def no_returns(x: int) -> int:
    """Doubles.

    Args:
        x (int): A number.
    """
    return 2 * x

def no_raises(**options: int) -> None:
    """Checks.

    Args:
        **options: Options.
    """
    if options:
        raise ValueError("no")

def re_raise() -> None:
    """Only re-raises."""
    try:
        pass
    except ValueError:
        raise

def nested_raise() -> None:
    """The raise belongs to the nested function."""
    def inner() -> None:
        raise ValueError
    del inner

def good(a: int, *rest: int) -> int:
    """Adds.

    Args:
        a: A number.
        *rest: More numbers.

    Returns:
        The sum.

    Raises:
        ValueError: When it is negative.
    """
    if a < 0:
        raise ValueError(a)
    return a + sum(rest)

def _private(x): pass

def unreachable(n: int) -> str:
    """Names it.

    Args:
        n: A number.

    Returns:
        Its name.
    """
    if n:
        return "some"
    raise AssertionError("unreachable")

class Thing:
    """A thing."""

    def __init__(self, size: float) -> None:
        self.size = size

    def __len__(self) -> int:
        return 1

    @property
    def volume(self) -> float:
        """Its volume, in cubic metres."""
        return self.size**3

    def step(self, dt: float) -> None:
        """See Base.step."""

    def grow(self, by: float) -> None:
        """Grows."""

class Documented:
    """A documented thing.

    Args:
        size: Its size.
    """

    def __init__(self, size: float) -> None:
        self.size = size

class Record(NamedTuple):
    """A record.

    Attributes:
        named: Documented in the class.
    """

    named: int
    own: float
    """Documented by its own docstring."""
    bare: str
'''


def test_the_rule_sees_each_missing_part() -> None:
    assert source_gaps(MADE_UP) == [
        "no_doc (line 2): no docstring",
        "missing_arg (line 4): Args: lacks y",
        "no_returns (line 15): no Returns: section",
        "no_raises (line 23): no Raises: section",
        "Thing.grow (line 94): no Args: section",
        "Thing (line 77): constructor: no Args: section",
        "Record (line 107): field bare undocumented",
    ]


def test_the_rule_counts_only_what_complies() -> None:
    assert count() == (len(_every_function()), len(_every_function()))


def _every_function() -> list[str]:
    return [
        name
        for path in _files()
        for name, function in _public_functions(ast.parse(path.read_text(encoding="utf-8")))
        if not _exempt(function)
    ]


if __name__ == "__main__":
    good, total = count()
    print(f"{good} of {total} public functions and methods comply")
