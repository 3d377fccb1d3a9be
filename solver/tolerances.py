"""Every numerical threshold the solver decides with, named once with its reason.

All are *relative*: they compare a quantity with the natural size of its problem, on
scale-normalised inputs (see analysis/normalisation.py), so no decision depends on units. Machine
precision is ε ≈ 2.2e-16; the designed frames zeromode builds have σ_r/σ_max ≳ 1e-4.

Algorithm parameters that are not thresholds (step sizes, iteration caps, size limits) live
beside the algorithm that uses them.
"""

# --- rank and null spaces -------------------------------------------------------------------

# σ_i ≤ RANK_RTOL·σ_max counts as zero (rank.decide_rank). Designed frames have σ_r/σ_max ≳ 1e-4
# and floating-point noise sits near 1e-15, so 1e-9 leaves several decades of margin each side.
RANK_RTOL = 1e-9

# Candidate placements (construction/placement.py) are ranked on small matrices of candidate rows; a gain
# counts only above 1e-7 of the largest singular value, so a nearly dependent bar (which would
# make a frame with a tiny singular-value gap) is not mistaken for an independent one.
PLACEMENT_RTOL = 1e-7

# --- geometry of the input ------------------------------------------------------------------

# Two joined nodes closer than this fraction of the frame's size are coincident (a bar of
# zero length): far below any meaningful design, far above round-off of the positions.
COINCIDENT_RTOL = 1e-12

# Points meant to be distinct (specified nodes, source and target sites, merged ports of two
# modules) closer than this fraction of their set's size are the same point.
DISTINCT_RTOL = 1e-9

# --- motions --------------------------------------------------------------------------------

# A motion whose part outside the rigid motions is below this fraction of its size is rigid;
# M motions are dependent modulo rigid motions when their smallest singular value is below
# this fraction of the largest. Requested motions are exact data, so round-off is the only noise.
RIGID_RTOL = 1e-9

# A mode's sign is decided by its largest entry (positive), and entries within this fraction of
# the largest magnitude tie (the first of them decides): a symmetric frame's mode has entries
# equal up to round-off, whose last bits differ between BLAS kernels (OpenBLAS's AVX2 and
# AVX-512 ones picked opposite signs for a 10 × 10 sheet's mode).
SIGN_TIE_RTOL = 1e-8

# A mode zeromode constructed must satisfy ‖C u‖ ≤ DESIGN_MODE_RTOL·‖C‖_F‖u‖ (normalised C)
# before a design is returned: the construction is exact, so only round-off (≈ 1e-15) remains.
DESIGN_MODE_RTOL = 1e-10

# A mode a *caller* hands in (JSON, often printed to 7–8 digits) may leave N(C) by this much.
GIVEN_MODE_RTOL = 1e-6

# --- polynomial roots and quadric constraints -----------------------------------------------

# A root of a solution-space polynomial is real when |Im| ≤ ROOT_IMAG_RTOL·(1 + |Re|); numpy's
# companion-matrix roots of the low-degree polynomials used here are accurate to ~1e-12.
ROOT_IMAG_RTOL = 1e-9

# A sample (x_U, u_U) satisfies the bar constraints (x_Si − x_U)·(u_Si − u_U) = 0 of the
# normalised problem when each is below this; b ∈ R(Ã) when the residual of its projection
# onto R(Ã)^⊥ is below this fraction of |b|.
CONSTRAINT_ATOL = 1e-9

# --- finite motion --------------------------------------------------------------------------

# The finite-motion fidelity ε (finite_motion.fidelity) at or below which a target counts as
# reached: IPOPT's tolerance 1e-8 on squared lengths gives ε of order 1e-7 at best.
REACHED_EPS = 1e-6

# A motion aimed at a target value of a quantity (motion/target.py) ends where the quantity is
# within TARGET_RTOL of it (relative to the quantity's scale: the target distance for a distance,
# 1 for an angle in radians or a strain); Newton on the augmented system converges
# quadratically, so it goes to round-off (≈ 1e-15) and this leaves five decades of margin.
TARGET_RTOL = 1e-10

# --- modules as maps ------------------------------------------------------------------------

# A module's map meets a requested feature (d_out = f(d_in) relative to the requested distance,
# f′ relative to max(1, |f′|)) and a chain's conformation its iterates (d_{k+1} = f(d_k),
# relative to d_k) within this: the promise of /v1/design/sequential (arXiv 1906.08400's
# designs, verified by continuation). Exact evaluation by Newton reaches ≈ 1e-13.
MAP_RTOL = 1e-8
