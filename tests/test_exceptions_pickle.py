"""Every simbridge error pickles and comes back as itself: a study's jobs run in other processes
(the local pool, Dask) and their errors must reach the caller with their class, message and
attributes (a UrdfNotFoundError raised in a worker did not unpickle in the parent, and the
study reported a dead worker instead of the missing file)."""

from __future__ import annotations

import inspect
import pickle

import pytest

from simbridge import exceptions as exc

ERRORS = [
    getattr(exc, name)
    for name in exc.__all__
    if isinstance(getattr(exc, name), type) and issubclass(getattr(exc, name), exc.SimbridgeError)
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
