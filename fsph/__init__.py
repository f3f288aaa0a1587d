"""fsph: axisymmetric FEM-SPH hydrocode for high-velocity impact."""

from .errors import DeckError, FsphError, SimulationError
from .simulation import Simulation, threads

__version__ = "0.1.0"
__all__ = ["Simulation", "threads", "DeckError", "FsphError", "SimulationError", "__version__"]
