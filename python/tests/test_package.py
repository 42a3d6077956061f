"""The package itself: its docstring example, its stubs."""

import doctest
import inspect
import pathlib

import fracbms


def test_the_docstring_example_runs():
    r = doctest.testmod(fracbms)
    assert r.attempted >= 5 and r.failed == 0


def test_stubs_name_every_public_item_with_its_keywords():
    stub = (pathlib.Path(fracbms.__file__).parent / "_fracbms.pyi").read_text()
    assert (pathlib.Path(fracbms.__file__).parent / "py.typed").exists()
    for name in fracbms.__all__:
        assert name in stub, name
        obj = getattr(fracbms, name)
        if callable(obj):
            assert obj.__doc__ and len(obj.__doc__) > 80, name
            for p in inspect.signature(obj).parameters:
                assert p in stub, (name, p)
