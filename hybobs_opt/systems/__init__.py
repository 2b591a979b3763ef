"""The nouns a user describes: PWA systems, hybrid automata, constant-drift and scalar-nonlinear systems."""

from .hybrid import Edge, HybridAutomaton, Location
from .polytope import Polytope
from .pwa import PWAMode, PWASystem

__all__ = ["Edge", "HybridAutomaton", "Location", "PWAMode", "PWASystem", "Polytope"]
