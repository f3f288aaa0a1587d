"""fsph: axisymmetric FEM-SPH hydrocode for high-velocity impact."""

from .errors import DeckError, FsphError, SimulationError
from .simulation import Simulation, threads
from .sweep import sweep

__version__ = "0.1.0"
__all__ = ["Simulation", "threads", "sweep", "DeckError", "FsphError", "SimulationError",
           "__version__"]
