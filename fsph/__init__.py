"""fsph: axisymmetric FEM-SPH hydrocode for high-velocity impact.

Simulation, threads and sweep are imported on first use (the solver,
numpy and h5py with them: about 0.3 s), not with the package, so that the
command line (fsph.cli), which imports the package first, takes over
Ctrl-C before they load; nothing else is imported here for that reason."""

import sys

from .errors import DeckError, FsphError, SimulationError

__version__ = "0.1.0"
__all__ = ["Simulation", "threads", "sweep", "DeckError", "FsphError", "SimulationError",
           "__version__"]


def __getattr__(name):
    """Simulation, threads and sweep, imported from their modules on first use."""
    if name == "sweep":
        from .sweep import sweep as value
    elif name in ("Simulation", "threads"):
        from . import simulation
        value = getattr(simulation, name)
    else:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(__all__))


class _Package(type(sys)):
    """The package, whose `sweep` stays the function (fsph.sweep.sweep):
    the import system sets a submodule as an attribute of its package
    when it first imports it, which would put the module fsph.sweep in
    the function's place."""

    def __setattr__(self, name, value):
        if name == "sweep" and isinstance(value, type(sys)):
            return
        super().__setattr__(name, value)


sys.modules[__name__].__class__ = _Package
