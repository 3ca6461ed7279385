"""The installed package: submodules, docstrings and type stubs ship with the wheel."""

import importlib
import inspect
import pathlib

import visguide


def test_every_public_name_has_a_docstring():
    for mod in ["mser", "lwpr", "fd", "tracking"]:
        m = importlib.import_module(f"visguide.{mod}")
        assert m.__doc__
        for name in m.__all__:
            obj = getattr(m, name)
            if callable(obj):
                assert inspect.getdoc(obj), f"visguide.{mod}.{name}"


def test_type_stubs_are_installed_and_cover_the_compiled_module():
    root = pathlib.Path(visguide.__file__).parent
    assert (root / "py.typed").exists()
    stub = (root / "_visguide.pyi").read_text()
    from visguide import _visguide

    for name in dir(_visguide):
        if not name.startswith("_"):
            assert f"def {name}(" in stub or f"class {name}" in stub, name
