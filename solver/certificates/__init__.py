"""Certificates: what a design can be trusted for.

``prestress`` certifies self-stresses, prestress stability and the rigidity margin of a design by
semidefinite programs (cvxpy, Clarabel); ``stiffness`` brackets the optimal-stiffness margin of
large frames; ``fabrication`` states how precisely a design must be built.
"""
