"""Every numerical threshold the solver decides with, named once with its reason.

Each compares a quantity with the natural size of its problem: relative to a size its comment
names (the *_RTOL), or absolute on scale-normalised inputs (see analysis/normalisation.py),
where that size is 1 (the *_ATOL, *_XTOL); so no decision depends on units. Machine precision is ε ≈ 2.2e-16; the
designed frames zeromode builds have σ_r/σ_max ≳ 1e-4. The first sections hold thresholds
several stages share; the rest follow the solver's stages, each name with the module it serves.

Algorithm parameters that are not thresholds (step sizes, iteration caps, size limits) live
beside the algorithm that uses them, except the few small ones (a finite-difference step, a
regulariser, a stated perturbation, a time floor), which are here, marked "Not a threshold":
tests/test_architecture.py fails on any float literal in [1e-16, 1e-4] in solver/ outside this
file, so none is a bare magic number.
"""

# --- rank and null spaces -------------------------------------------------------------------

# σ_i ≤ RANK_RTOL·σ_max counts as zero (rank.decide_rank). Designed frames have σ_r/σ_max ≳ 1e-4
# and floating-point noise sits near 1e-15, so 1e-9 leaves several decades of margin each side.
RANK_RTOL = 1e-9

# Candidate placements (construction/placement.py) are ranked on small matrices of candidate rows; a
# gain counts only above 1e-7 of the largest singular value, so a nearly dependent bar (which would
# make a frame with a tiny singular-value gap) is not mistaken for an independent one.
PLACEMENT_RTOL = 1e-7

# --- geometry of the input ------------------------------------------------------------------

# Two joined nodes closer than this fraction of the frame's size are coincident (a bar of
# zero length): far below any meaningful design, far above round-off of the positions.
COINCIDENT_RTOL = 1e-12

# Two nodes without a bar between them closer than this fraction of the shortest bar collide: a
# motion's usable range ends there (applications/strain_range.py, motion/target.py), and a sheet
# whose reference is already that close is refused (applications/lattice.py). Not round-off: a
# physical choice, a tenth of a bar, far from touching for bars drawn as lines.
PROXIMITY_FRACTION = 0.1

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
# companion-matrix roots of the low-degree polynomials used here are accurate to ~1e-12. (The
# quadratic in y of two conics' common points, construction/multimode.py, takes it as |Im| ≤
# ROOT_IMAG_RTOL: y is a normalised coordinate, |y| ≲ 1.)
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

# A motion that moves the boundary along x by at most this fraction of its move along y does
# not stretch the frame along x, so ν = −ε_y/ε_x has no value (motion/boundary_strain.py): ε_x is
# a difference of means of exact data, zero up to round-off (≈ 1e-16 relative) when the mode does
# not pull along x.
NO_STRETCH_RTOL = 1e-14

# --- analysis: null spaces and eigenpairs of large frames -----------------------------------

# δ in K + δI (analysis/eigen.py), relative to the mean diagonal of K: below the wanted
# eigenvalues (down to ~1e-12 of the scale: the uniform margin of a chain of 64 blocks), so that
# they stay apart in the inverse, and three decades above the round-off of a Cholesky
# factorisation (~1e-16), so that K + δI is numerically positive definite; a factorisation that
# fails retries eigen.SHIFT_RETRY times larger.
EIGEN_SHIFT_RTOL = 1e-13

# ARPACK's convergence tolerance (relative to the Ritz value of the inverse): machine level.
ARPACK_TOL = 1e-14

# δ = NULL_SHIFT_RTOL·σ_max² in CᵀC + δI, the shift of analysis/rigidity.py's sparse null space: 10³
# times the round-off of forming CᵀC (≈ 1e-16 σ_max²), so the factorisation sees a positive definite
# matrix (up to 10⁶ nodes, 2D and 3D lattices and near-isostatic networks), and below σ² of the
# singular values of designed frames and lattice patches (σ ≳ 1e-4 σ_max), so a shift-invert step
# damps such a direction by δ/(σ² + δ) relative to the null space. Directions with σ² below δ (σ ≲
# 3e-7 σ_max, yet above the rank threshold RANK_RTOL·σ_max) are damped by less than half per step:
# the iteration cannot tell them from the null space, and a block narrower than all of them
# converges to a mixture whose Ritz value stalls above the threshold, a zero mode missed. So the
# block is widened until its largest Ritz value is one the shift damps (θ² ≥ δ); Rayleigh–Ritz on C
# then separates the null space from those singular values. Near-degenerate frames have such
# directions (disordered near-isostatic networks of 10⁴ nodes reach σ_r ≈ 2e-7 – 6e-5 σ_max). A
# larger shift leaves more of them undamped (δ = 1e-10 σ_max² with a second factorisation at 1e-13
# when needed: 1.5–1.8× slower counts on those networks at 10⁴ nodes; the same on lattices).
NULL_SHIFT_RTOL = 1e-13
# The null-space bases of analysis/rigidity.py's sparse route are iterated until ‖C v‖ ≤
# BASIS_ANGLE·σ_r for every basis vector v, which bounds the angle between the returned and the
# exact null space by BASIS_ANGLE (round-off allowing).
BASIS_ANGLE = 1e-10
# … or until ‖C v‖ ≤ BASIS_ROUNDOFF_RTOL·σ_max, the level round-off in C·v (≈ 1e-16 σ_max per entry,
# summed over a node's bars) keeps it above; or, where a singular value below the rank's
# threshold lies above both (a near-degenerate frame), until ‖C v‖ is at most the largest Ritz
# value counted as zero, which its singular vector cannot go below.
BASIS_ROUNDOFF_RTOL = 1e-13

# Rayleigh–Ritz's SVD of its small triangular factor by one-sided Jacobi (analysis/
# sparse_kernels.py): a column pair counts as orthogonal once |r_jᵀ r_l| ≤ JACOBI_TOL ‖r_j‖ ‖r_l‖: a
# few units of round-off, the accuracy the rotations themselves reach; Jacobi converges
# quadratically, and past sparse_kernels.JACOBI_MAX_SWEEPS sweeps (never seen) the SVD falls back to
# LAPACK's.
JACOBI_TOL = 1e-15
# In analysis/sparse_kernels.py's null-space rounds, a vector that keeps at most this fraction of
# its norm after its parts along the null vectors and the Ritz space are removed lies in that
# space (round-off after two Gram–Schmidt passes).
RITZ_SPACE_RTOL = 1e-12

# --- construction ---------------------------------------------------------------------------

# A design's report (construction/design.py) states σ_r of its frame (its conditioning):
# converged to this relative bound, as a full SVD would give it (designs are small: the sparse
# route's few extra solves cost microseconds), and reported with the bound reached when round-off
# keeps it coarser.
REPORT_GAP_RTOL = 1e-9

# Gauss–Newton on a pair of helper nodes (construction/hierarchical_pairs.py) has solved it when
# the residual of the pair's 2d ≤ 6 equations is below this (normalised units, O(1) entries):
# round-off, so the placed pair meets its bars as exactly as a placement does.
PAIR_NEWTON_ATOL = 1e-13
# Not a threshold: the central-difference step of that Gauss–Newton's Jacobian (normalised units,
# 2d ≤ 6 unknowns); an inexact Jacobian slows the iteration, not the residual it reaches.
PAIR_JACOBIAN_STEP = 1e-7

# Common points of the position sets (construction/multimode.py, normalised coordinates, O(1)).
# Two conics meet where the resultant (degree 4 in x) vanishes; a tangency makes a double root,
# which numpy's companion matrix splits into a complex pair with |Im| ~ √ε ≈ 1e-8, so a root
# counts as real up to RESULTANT_ROOT_IMAG_RTOL·(1 + |Re|) (Gauss–Newton then polishes it, and a
# false root fails COMMON_POSITION_ATOL) ...
RESULTANT_ROOT_IMAG_RTOL = 1e-7
# ... and y follows from the resultant's linear factor m₁(x) y = −m₀(x) unless |m₁(x)| is at most
# this (a tangency or a shared vertical: then y is taken from the quadratic itself).
RESULTANT_PIVOT_ATOL = 1e-12
# Gauss–Newton from seeded starts stops once its step is at round-off ...
QUADRIC_STEP_ATOL = 1e-14
# ... and keeps the points on every quadric to this (four decades above the round-off of
# evaluating [x;1]ᵀQ[x;1] with O(1) entries; a point off a quadric converges to nothing).
COMMON_POSITION_ATOL = 1e-10
# Starts that converge to the same common point agree to this: a point where quadrics meet
# tangentially is reached only to about √ε ≈ 1e-8 (linear convergence), so 1e-6 keeps one copy.
SAME_SOLUTION_ATOL = 1e-6

# --- motion: continuation, periodic frames, targets, refinement -----------------------------

# Continuation along a finite motion (motion/finite_motion.py, normalised units). Newton's corrector
# stops when every bar is within this relative length error (the API promises ≤ 1e-9).
NEWTON_RTOL = 1e-12
# A direction (a requested mode, the previous tangent, a chord between samples) whose part along
# the nontrivial zero modes is at most this fraction of its norm has none there (no tangent):
# the modes' basis is orthonormal to round-off, and a direction meant along them keeps O(1).
TANGENT_RTOL = 1e-8
# Locating a singular point, Newton goes on while it contracts (finite_motion.TIGHT_CONTRACTION)
# and stops once its step is at round-off (normalised coordinates are O(1)).
TIGHT_STEP_ATOL = 1e-15
# The continuation has reached its amplitude when the path parameter τ is within this fraction of
# it: τ is a sum of step lengths, so round-off may leave it a few ulps short.
AMPLITUDE_RTOL = 1e-12
# A continuation step whose corrector fails or whose tangent turns too far is halved down to this
# (path parameter, normalised units) before the continuation gives up ("stalled"): a step that
# short makes no progress along any motion, yet stays far above round-off of the positions.
CONTINUATION_MIN_STEP = 1e-9
# Zero modes at a located singular point are counted with this relative threshold: a branch
# point can be located only to about √(machine ε) ≈ 1e-8, and σ vanishes linearly there.
SINGULAR_RTOL = 1e-6
# A singular point counts as located once the vanishing singular value is this far below the
# counting threshold (two decades of margin for the count at SINGULAR_RTOL).
LOCATED_RTOL = 1e-2 * SINGULAR_RTOL
# ... its σ measured only once the bracket on the step length is this narrow (relative).
MEASURED_WIDTH = 1e-5
# The location stops there, or once the bracket on the step length is at round-off (relative to
# max(h, 1)).
BRACKET_ROUNDOFF = 1e-15
# The closest point of a path to a target between two samples (finite_motion.curve_minimum) is
# located by Brent's bounded search to this much of the path parameter: round-off of a parameter
# of size O(1), each evaluation a corrector to NEWTON_RTOL.
CURVE_MINIMUM_XATOL = 1e-12

# Periodic frames (motion/periodic.py).
# A tiled configuration whose bars are off by more than this (relative) is not a translate of
# the cell's: the frame is not the tiling it was said to be.  Also the tolerance (relative to
# the frame's size) within which find_tiling matches a translated node to a node.
TILING_RTOL = 1e-9
# find_tiling's periods are independent when the smallest singular value of their rows is above this
# fraction of the largest.
PERIOD_INDEPENDENT_RTOL = 1e-6

# Aiming at a target (motion/target.py), Brent's method brackets the crossing on the curve to this
# fraction of the samples' spacing before Newton on the augmented system finishes it (Newton's basin
# is far wider).
TARGET_BRACKET_RTOL = 1e-6

# IPOPT's tol, its relative KKT error at convergence, for the refinement of a design
# (motion/refine.py, the pipeline's RefineStage) and of a sheet's module (applications/
# finite_strain.py): on squared bar lengths of normalised frames it gives ε of order 1e-7
# (REACHED_EPS leaves a decade). The default of the API's refine.tol.
IPOPT_TOL = 1e-8
# Not a threshold: refinement's progress report divides the elapsed time by the solve's time
# limit, which counts as at least this many seconds (a budget already spent reports "done"
# instead of dividing by zero).
REPORT_MIN_TIME_S = 1e-9

# --- applications ---------------------------------------------------------------------------

# Allosteric designs (applications/allostery.py; network_allostery.py holds its answers to the
# same). An answer's target error ‖achieved − u_tgt‖/‖u_tgt‖ must not exceed this (the issue's
# floor); an exact construction reaches ~1e-13, so this leaves four decades for the frame's
# conditioning.
TARGET_ERROR_MAX = 1e-9
# The relative singular-value gap σ_min/σ_max of the unit compatibility matrix past the designed
# zero modes must reach this: well-built chains have 1e-3 … 1e-2 (measured, benchmarks/
# bench_allostery.py); below 1e-6 a second soft mode is six decades from being a zero mode and
# the frame's own rank decisions (RANK_RTOL = 1e-9 of C) are no longer safely away from it.
GAP_FLOOR = 1e-6
# Not a threshold: the stated perturbation of the sensitivity figure: node displacements of
# Euclidean norm SENSITIVITY_PERTURBATION × the site size (all nodes together, worst direction).
SENSITIVITY_PERTURBATION = 1e-6

# Two second moments of a set of nodes within this fraction of the largest leave their principal
# axes undecided (certificates/stiffness.principal_axes, allostery's canonical axes across the
# sites' axis): nodes symmetric by construction agree to round-off, distinct moments of a
# generic design differ by O(1).
AXES_RTOL = 1e-6

# Allostery inside a given network (applications/network_allostery.py; its answers meet
# TARGET_ERROR_MAX too).
# A bar is left unstrained by the response when |(x_i − x_j)·(u_i − u_j)| ≤ this × |x_i − x_j|
# × max|u|: exact data give zero or O(1); round-off of the products is ~1e-16.
UNSTRAINED_RTOL = 1e-12
# A node is loose when it moves by more than this fraction of the largest amplitude in a zero
# mode of the frame without the strained bars (exact zeros elsewhere are ~1e-15).
LOOSE_RTOL = 1e-8
# A pair node swung about its kept ground neighbours strains the pair only when the swing has a
# part along the pair's axis above this fraction of the axis (a swing across it is first-order
# useless; the geometry is exact data, so its part is zero or O(1)).
SWING_RTOL = 1e-6

# Spring networks and their bond Green's function (analysis/bond_green.py; the elastic response
# model, applications/elastic_allostery.py, and the tuning-by-pruning peer). A bar's stiffness
# change (a removal included) is refused when 1 − (k_b − k) G_bb, the share of a force dipole on
# its ends the rest carries, falls to this: the new softest mode would be softer than 1e-8 of the
# bar's own stiffness (singular value ≳ 1e-4 of the bar's), far above the 1e-9 singular-value
# threshold of the project's rank decisions (RANK_RTOL).
FLOPPY_RTOL = 1e-8
# An elastic edit is refused when it softens the network's softest nontrivial stiffness mode below
# this fraction of the given network's: pruned networks keep 1e-3 … 0.3 of it on the issue's
# tasks (measured, benchmarks/bench_allostery.py part "edits"), a new zero mode keeps nothing
# (≲ 1e-12, round-off).
SOFTEST_MODE_RTOL = 1e-4

# Sheets held to a Poisson ratio over a strain range (applications/finite_strain.py).
# The module search compares candidates' ranges: their events are located to this strain (the chosen
# module's range is then scanned to round-off).
COVER_XTOL = 1e-5
# A bar of the verified sheet (the lattice's promise; its module is exact to ≈ 1e-13) may change its
# length by at most this much (relative).
SHEET_BAR_RTOL = 1e-9
# Strain samples on a grid from 0 (arange's end, the reference's exclusion) are compared with
# this much slack (in strain, or relative to the range): grid arithmetic leaves round-off.
SAMPLE_ROUNDOFF = 1e-12
# The box the unspecified nodes stay inside is shrunk by this (relative) below the reach that
# would admit one more neighbour, so that floor() of the reach does not round up at the edge.
BOX_SHRINK_RTOL = 1e-9
# Not a threshold: the weight of the reference's departure from the warm start in the module's
# IPOPT objective, ‖q₀ − q₀⁰‖²/‖q₀⁰‖² (refine_module): small beside the objective's other terms,
# it keeps the refined reference near the warm start where they leave it free.
MODULE_REFINE_REGULARISER = 1e-4

# Symmetric sheet modules (applications/sheet_module.py).
# Newton on g(q) = 0 stops when every bar orbit is within this relative error of its squared
# length (the lattice promises ≤ 1e-9 on bar lengths; round-off is ~1e-15).
MODULE_NEWTON_RTOL = 1e-13
# A Cardan trammel's matrix M (M² = P Pᵀ of the corner and stretched-corner columns) is
# degenerate when |det M| is at most this times tr(M²) = Σμ: its entries are O(1) exact data, so
# a generic M has |det M| of that order, a degenerate one round-off.
TRAMMEL_DEGENERATE_RTOL = 1e-12

# A sheet's usable strain range (applications/strain_range.py): events are bracketed between the
# scan's steps and located to this strain (round-off of a strain of O(0.1)) ...
STRAIN_XTOL = 1e-13
# ... but where Newton stops converging (a fold of the symmetric curve: the strain turns back), the
# end is located by bisection on Newton's success; Newton's basin shrinks like √|ε − ε*| there, so
# the fold is located to about this much.
FOLD_XTOL = 1e-9

# --- certificates ---------------------------------------------------------------------------

# Fabrication tolerance (certificates/fabrication.py): Gauss–Newton assembly of a frame with
# perturbed lengths has converged when its last step is this small relative to √n (normalised
# units).
ASSEMBLY_TOL = 1e-12
# A statistic's sensitivity below this per unit error does not change to first order (round-off is
# ~1e-15).
INSENSITIVE = 1e-12

# Prestress stability (certificates/prestress.py).
# t* ≤ PRESTRESS_TOL counts as zero. t* is dimensionless (unit stress, unit flexes); Clarabel
# brackets it to ~1e-9, SCS to ~1e-6, stable frames of interest have t* ≳ 1e-4.
PRESTRESS_TOL = 1e-6
# A solved margin SDP must close its bracket to this relative gap (else the fallback runs).
MARGIN_GAP_RTOL = 1e-4
# SCS's eps_abs and eps_rel on the certificate SDPs: its default 1e-4 leaves the prestress
# bracket straddling PRESTRESS_TOL, so it is asked for a decade below that.
SCS_EPS = 1e-7

# Optimal stiffness (certificates/stiffness.py). Symmetry reduction: a node maps onto a node when
# their normalised positions agree to this (exact symmetry only: the sheets zeromode builds are
# symmetric to round-off); a motion subspace is invariant when its image leaves it by at most this
# fraction.
SYMMETRY_ATOL = 1e-9
SYMMETRY_INVARIANT_RTOL = 1e-7
# Step lengths of the interior-point blocks larger than stiffness.DENSE_STEP come from a Lanczos
# Ritz value to this relative accuracy (13 % faster on the 20 × 20 sheet than LAPACK's partial
# eigen-solver): a step length is a fraction of the way to the cones' boundary, not a decision.
LANCZOS_RTOL = 1e-4
# An interior-point step whose primal and dual lengths multiply to less than this has stalled
# (Ritz values and round-off keep the factors from being definite at any usable length).
STEP_PRODUCT_MIN = 1e-12
# The bundle method's subspaces are orthonormalised with this rank threshold: eigenvectors of k̂
# and bundle columns already spanned (to about √ε after the projection off the span) drop out.
BUNDLE_RANK_RTOL = 1e-8

# --- multistable designs --------------------------------------------------------------------

# A relaxation of the rods-and-springs energy from a perturbed minimum lands back in it when it
# ends within this distance (over RMS radius · √N, modulo rigid motions): the relaxation ends
# with Newton steps, quadratically convergent to round-off (≈ 1e-14 here; the stiff rods make the
# Hessian's conditioning ~1e7, which can cost a few decades), and other minima lie ~0.1 away, so
# 1e-6 tells "the same minimum" from any other by orders of magnitude either side.
MINIMUM_LANDING_RTOL = 1e-6

# Springs the interior-point solver leaves with a stiffness below this fraction of k_max are
# absent (Clarabel returns zeros as values of its tolerance, ~1e-8 and below); the least change
# of the rest lengths then restores E′ = 0 exactly (multistable/springs.py).
SPRING_DROP_RTOL = 1e-7

# The relaxations of multistable/verify.py stop their trust region at a gradient of this, in
# units of k_max · RMS radius: round-off of the energy's gradient with rods 10⁵ stiffer than the
# springs is ~1e-16 · 1e5; Newton steps then polish to round-off.
RELAXATION_GRADIENT_RTOL = 1e-11

# --- modules as maps ------------------------------------------------------------------------

# A module's map meets a requested feature (d_out = f(d_in) relative to the requested distance,
# f′ relative to max(1, |f′|)) and a chain's conformation its iterates (d_{k+1} = f(d_k),
# relative to d_k) within this: the promise of /v1/design/sequential (arXiv 1906.08400's
# designs, verified by continuation). Exact evaluation by Newton reaches ≈ 1e-13.
MAP_RTOL = 1e-8

# Exact evaluation of a module's map (sequential/module_map.py, Gauss–Newton on the bar lengths and
# d_in = d): converged once a correction is below MAP_STEP_RTOL of the module's RMS radius and
# every bar and d_in are met, their squared lengths within MAP_RESIDUAL_RTOL of themselves
# (lengths within half of it): far below MAP_RTOL, a few decades above round-off (≈ 1e-16).
MAP_STEP_RTOL = 1e-14
MAP_RESIDUAL_RTOL = 1e-13

# Fixed points of a map, located by Brent's method on f(d) − d between samples: to this relative
# width, a few ulps (f is exact to ≈ 1e-13, so the fixed point is as exact as f allows).
FIXED_POINT_RTOL = 1e-15

# IPOPT's KKT tolerance in a module's design (sequential/design.py): the map points are equality
# constraints met to round-off long before; the answer is verified to MAP_RTOL by continuation.
MAP_IPOPT_TOL = 1e-12

# --- branched motions (multistable/bifurcation.py) --------------------------------------------

# A branching dyad's spanned distance d counts as largest (smallest) over the traced motion at
# the branch conformation when no path sample exceeds (undercuts) it by more than this fraction:
# the samples carry the continuation's bar error (~1e-10) and d is only stationary there, so
# the nearest sample sits below (above) it by ~d″·step², far above this.  The same bound, on
# the unit tangent's scale, declares a relative velocity g zero (no line of stationary d).
STATIONARY_RTOL = 1e-9
