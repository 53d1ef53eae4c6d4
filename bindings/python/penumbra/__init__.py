"""penumbra: soft shadows from area lights and HDR environment maps (see help(penumbra)).

The package re-exports the compiled extension `penumbra._penumbra` (pybind11 over the C++ API);
its docstring, read from the extension, is the module's. Type stubs for editors are in
__init__.pyi beside this file (PEP 561, with py.typed).
"""
from . import _penumbra
from ._penumbra import *  # noqa: F401,F403 -- every public name of the extension
from ._penumbra import __version__

__doc__ = _penumbra.__doc__
__all__ = sorted(name for name in vars(_penumbra) if not name.startswith("_"))


def _present_as_penumbra() -> None:
    """Shows the extension's classes and functions as penumbra.X (their repr, help, pickling
    path) rather than penumbra._penumbra.X, which is where they are defined."""
    for name in __all__:
        obj = getattr(_penumbra, name)
        if getattr(obj, "__module__", None) == _penumbra.__name__:
            try:
                obj.__module__ = __name__
            except (AttributeError, TypeError):  # a builtin that does not allow it
                pass


_present_as_penumbra()
del _present_as_penumbra
