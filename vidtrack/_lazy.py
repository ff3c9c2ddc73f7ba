"""Names of a package loaded from its modules on first use (PEP 562), written once.

A package's ``__init__`` lists which module holds which name and takes its
``__getattr__`` and ``__dir__`` from :func:`lazy_exports`; importing one module of the
package (``vidtrack.footage.timebase``, say) then loads none of the others, and
``from vidtrack.footage import open_source`` loads only what it needs.
"""

import importlib

__all__ = ["lazy_exports"]


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
