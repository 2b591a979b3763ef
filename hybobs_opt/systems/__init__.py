"""The nouns a user describes: PWA systems, hybrid automata, constant-drift and scalar-nonlinear systems."""

from .constant_drift import ConstantDriftSystem
from .hybrid import Edge, HybridAutomaton, Location
from .polytope import Polytope
from .pwa import PWAMode, PWASystem
from .scalar_nonlinear import ScalarFunction, ScalarNonlinearSystem

__all__ = ["ConstantDriftSystem", "Edge", "HybridAutomaton", "Location", "PWAMode", "PWASystem", "Polytope", "ScalarFunction", "ScalarNonlinearSystem"]
