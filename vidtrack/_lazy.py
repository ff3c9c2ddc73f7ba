"""Names of a package loaded from its modules on first use (PEP 562), written once.

A package's ``__init__`` lists which module holds which name and takes its
``__getattr__`` and ``__dir__`` from :func:`lazy_exports`; importing one module of the
package (``vidtrack.footage.timebase``, say) then loads none of the others, and
``from vidtrack.footage import open_source`` loads only what it needs.
"""

import importlib
import types

__all__ = ["lazy_exports", "callable_package"]


def lazy_exports(package, exports):
    """``(__getattr__, __dir__, names)`` for ``package`` with ``exports`` {module: names}."""
    module_of = {name: module for module, names in exports.items() for name in names}
    namespace = importlib.import_module(package).__dict__

    def __getattr__(name):
        module = module_of.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(module), name)
        namespace[name] = value
        return value

    def __dir__():
        return sorted(set(namespace) | set(module_of))

    return __getattr__, __dir__, list(module_of)


def _call_target(package):
    module, name = package.__dict__["__call_target__"]
    return getattr(importlib.import_module(module), name)


class _CallablePackage(types.ModuleType):
    """A package that, called, calls one function of one of its modules (loaded then).

    Only dunder names here: any other would be hidden by a submodule of that name."""

    def __call__(self, *args, **kwargs):
        return _call_target(self)(*args, **kwargs)

    @property
    def __signature__(self):
        import inspect

        return inspect.signature(_call_target(self))


def callable_package(package, module, name):
    """Make ``package`` callable as ``module.name`` and return it.

    For a package whose public function has the package's name (``vidtrack.track`` and
    its ``track``): ``from vidtrack import track`` gives the package, which must then be
    callable, while ``vidtrack.track.tracker`` stays importable (a function in its place
    would hide the package from ``import vidtrack.track.tracker as t``). The package is
    imported (its ``__init__`` must stay light); ``module`` only on the first call.
    """
    pkg = importlib.import_module(package)
    pkg.__dict__["__call_target__"] = (module, name)
    pkg.__class__ = _CallablePackage
    return pkg
