"""Every simbridge error pickles and comes back as itself: a study's jobs run in other processes
(the local pool, Dask) and their errors must reach the caller with their class, message and
attributes (a UrdfNotFoundError raised in a worker did not unpickle in the parent, and the
study reported a dead worker instead of the missing file)."""

from __future__ import annotations

import inspect
import pickle

import pytest

from simbridge import exceptions as exc
from simbridge.compare import errors as compare_errors

ERRORS = [
    getattr(module, name)
    for module in (exc, compare_errors)
    for name in module.__all__
    if isinstance(getattr(module, name), type)
    and issubclass(getattr(module, name), exc.SimbridgeError)
]


def _example(cls: type[exc.SimbridgeError]) -> exc.SimbridgeError:
    """An instance built from made-up arguments of the types its ``__init__`` declares."""
    args: list[object] = []
    for p in list(inspect.signature(cls.__init__).parameters.values())[1:]:
        if p.default is not p.empty or p.kind in (p.VAR_POSITIONAL, p.VAR_KEYWORD):
            continue
        kind = str(p.annotation)
        if "Iterable" in kind or "Sequence" in kind:
            args.append(["first", "second"])
        elif "BaseException" in kind:
            args.append(ValueError("the cause"))
        elif "float" in kind:
            args.append(1.5)
        elif "int" in kind and "str" not in kind:
            args.append(3)
        else:
            args.append(f"{p.name}-value")
    return cls(*args)


def test_every_error_is_listed() -> None:
    assert len(ERRORS) >= 28  # the module's classes, not an empty list by accident


@pytest.mark.parametrize("cls", ERRORS, ids=lambda c: c.__name__)
def test_every_error_comes_back_from_pickle_as_itself(cls: type[exc.SimbridgeError]) -> None:
    err = _example(cls)
    back = pickle.loads(pickle.dumps(err))
    assert type(back) is cls
    assert str(back) == str(err)
    assert back.args == err.args
    assert back.__dict__ == err.__dict__
    assert isinstance(back, exc.SimbridgeError)


MOVED = [
    "ScenarioError",
    "TrajectoryFileError",
    "CacheEntryMissingError",
    "JobError",
    "EngineNotInStudyError",
    "ExtraNotInstalledError",
]


def test_compare_errors_are_simbridge_errors_of_the_same_builtins() -> None:
    assert sorted(compare_errors.__all__) == sorted(MOVED)
    assert issubclass(compare_errors.ScenarioError, ValueError)
    assert issubclass(compare_errors.TrajectoryFileError, ValueError)
    assert issubclass(compare_errors.CacheEntryMissingError, LookupError)
    assert issubclass(compare_errors.JobError, RuntimeError)
    assert issubclass(compare_errors.EngineNotInStudyError, exc.InvalidArgumentError)
    assert issubclass(compare_errors.ExtraNotInstalledError, ImportError)
    assert not set(MOVED) & set(exc.__all__)


@pytest.mark.parametrize("name", MOVED)
def test_a_compare_error_by_its_old_path_warns_and_is_the_same_class(name: str) -> None:
    with pytest.warns(DeprecationWarning, match=rf"simbridge\.compare\.errors\.{name}"):
        old = getattr(exc, name)
    assert old is getattr(compare_errors, name)
    with pytest.warns(DeprecationWarning):
        exec(f"from simbridge.exceptions import {name} as imported", {})


def test_an_unknown_name_of_the_exceptions_module_is_an_attribute_error() -> None:
    with pytest.raises(AttributeError, match="has no attribute 'NoSuchError'"):
        exc.NoSuchError  # noqa: B018
