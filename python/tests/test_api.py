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


# The extras each adapter adds to the options it shares with the others (documented
# in its docstring); nothing else may differ between the three constructors.
EXTRAS = {"fishcam.transforms": ["rng"], "fishcam.torch": ["min_visibility", "boxes"], "fishcam.albumentations": []}


@pytest.mark.parametrize("kind", ["RandomViewpoint", "RandomAffine"])
def test_the_three_adapters_take_one_set_of_options(kind):
    """The numpy, torch and albumentations constructors of a transform take exactly
    the options of its one definition (fishcam.ViewpointOptions / AffineOptions, each
    with the default of VIEWPOINT_DEFAULTS / AFFINE_DEFAULTS, keyword-only) plus their
    documented extras, and document each once: they were three hand copies that
    drifted (issue 38, item 4)."""
    import typing

    import fishcam.transforms as fx

    options, defaults = {
        "RandomViewpoint": (fishcam.ViewpointOptions, fx.VIEWPOINT_DEFAULTS),
        "RandomAffine": (fishcam.AffineOptions, fx.AFFINE_DEFAULTS),
    }[kind]
    shared = list(typing.get_type_hints(options))
    assert shared == list(defaults) and len(shared) >= 7
    leading = ["camera"] if kind == "RandomViewpoint" else []
    for module_name, extras in EXTRAS.items():
        cls = getattr(importlib.import_module(module_name), kind)
        parameters = inspect.signature(cls).parameters
        assert list(parameters) == leading + shared + extras, f"{module_name}.{kind}"
        for name in shared:
            assert parameters[name].kind is inspect.Parameter.KEYWORD_ONLY
            assert parameters[name].default == defaults[name], f"{module_name}.{kind}: {name}"
        doc = inspect.getdoc(cls)
        for name in leading + shared + extras:
            assert doc.count(f"\n    {name}: ") == 1, f"{module_name}.{kind} documents {name} once"
        # What the constructor takes is what its signature says: every name, and no other.
        cls(**{name: defaults[name] for name in shared})
        others = {name for names in EXTRAS.values() for name in names} - set(extras)
        for name in sorted(others) + ["nonsense"]:
            with pytest.raises(TypeError, match=f"unexpected keyword argument '{name}'"):
                cls(**{name: None})
    assert inspect.getdoc(options).count("\n    ") >= len(shared)


def test_albumentations_serialises_the_shared_options():
    """A.to_dict writes the shared options (p being albumentations' own) and the camera."""
    import fishcam.albumentations as fa
    import fishcam.transforms as fx

    viewpoint, affine = fa.RandomViewpoint(), fa.RandomAffine()
    assert viewpoint.get_transform_init_args_names() == ("camera", *[n for n in fx.VIEWPOINT_DEFAULTS if n != "p"])
    assert affine.get_transform_init_args_names() == tuple(n for n in fx.AFFINE_DEFAULTS if n != "p")
