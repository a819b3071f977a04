"""The package's public API is documented: every public class, function, method
and property of fishcam, fishcam.transforms, fishcam.torch, fishcam.albumentations
and fishcam.metrics has a docstring beyond its signature; transforms show their
parameters in repr; the stubs and py.typed ship with the package."""

import importlib
import inspect
import os

import fishcam
import pytest

MODULES = ["fishcam", "fishcam.transforms", "fishcam.metrics", "fishcam.torch", "fishcam.albumentations"]


def described(obj):
    """A docstring with more than pybind11's generated signature line."""
    lines = [line for line in (inspect.getdoc(obj) or "").splitlines() if line.strip()]
    name = getattr(obj, "__name__", None) or getattr(getattr(obj, "fget", None), "__name__", "")
    if lines and name and lines[0].startswith(f"{name}(") and "->" in lines[0]:
        lines = lines[1:]
    return bool(lines)


def public_api():
    for module_name in MODULES:
        module = importlib.import_module(module_name)
        for name in module.__all__:
            obj = getattr(module, name)
            if not (inspect.isclass(obj) or callable(obj)):
                continue  # constants
            yield f"{module_name}.{name}", obj
            if inspect.isclass(obj):
                for attribute, value in vars(obj).items():
                    if attribute.startswith("_") and attribute not in ("__call__",):
                        continue
                    if (
                        callable(value)
                        or isinstance(value, (property, staticmethod))
                        or type(value).__name__ in ("instancemethod", "builtin_function_or_method")
                    ):
                        yield f"{module_name}.{name}.{attribute}", value


API = list(public_api())


def test_the_api_was_found():
    assert len(API) >= 85, len(API)  # the loop below must not pass by finding nothing


@pytest.mark.parametrize("name,obj", API, ids=[name for name, _ in API])
def test_every_public_name_is_documented(name, obj):
    target = obj.__func__ if isinstance(obj, staticmethod) else obj
    assert described(target), f"{name}: no docstring"


def test_reprs_show_the_parameters():
    import fishcam.albumentations as fa
    import fishcam.torch as ft
    from fishcam.transforms import RandomAffine, RandomViewpoint

    for transform in [
        RandomViewpoint(preset="medium"),
        ft.RandomViewpoint(preset="medium"),
        fa.RandomViewpoint(preset="medium"),
    ]:
        assert "preset='medium'" in repr(transform) and "depth" in repr(transform), repr(transform)
    for transform in [RandomAffine(preset="small"), ft.RandomAffine(preset="small"), fa.RandomAffine(preset="small")]:
        assert "preset='small'" in repr(transform), repr(transform)


def test_stubs_and_py_typed_ship_with_the_package():
    folder = os.path.dirname(fishcam.__file__)
    assert os.path.isfile(os.path.join(folder, "py.typed"))
    assert os.path.isfile(os.path.join(folder, "_fishcam.pyi"))
