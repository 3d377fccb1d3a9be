"""zeromode.solver — the mathematics of zero-mode design for Maxwell frames.

Pure functions over numpy arrays and small frozen dataclasses; no web code.
Vocabulary follows Kim, Lu, Strogatz & Bassett, "Conformational control of
mechanical networks": specified / unspecified nodes, compatibility matrix C,
self-stress, solution space, quadric.
"""

from zeromode.solver.analysis.rigidity import Analysis, analyze, compatibility_matrix, rigid_motions
from zeromode.solver.errors import DomainError, InvalidInput
from zeromode.solver.frame import Frame

__all__ = [
    "Analysis",
    "DomainError",
    "Frame",
    "InvalidInput",
    "analyze",
    "compatibility_matrix",
    "rigid_motions",
]
