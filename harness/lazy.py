"""Lazy re-exports for the packages' ``__init__``: a public name is imported from its module on first use.

A package's ``__init__`` lists ``{name: submodule}``; ``from sphrom.sph import run_sph`` then imports
``sphrom.sph.solver`` only then, so importing a package stays light (no numba, fmpy, scikit-fem, py-pde) and
no package import can close an import cycle.
"""

import importlib


def lazy_exports(package, exports):
    """(``__getattr__``, ``__dir__``) of the package ``package`` (its ``__name__``) for ``exports``.

    Parameters
    ----------
    package : str
        The package's ``__name__``.
    exports : dict
        {public name: submodule name relative to the package}.
    """

    def __getattr__(name):
        module = exports.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(f"{package}.{module}"), name)
        globals_ = importlib.import_module(package).__dict__
        globals_[name] = value                   # later look-ups skip __getattr__
        return value

    def __dir__():
        return sorted(set(importlib.import_module(package).__dict__) | set(exports))

    return __getattr__, __dir__
