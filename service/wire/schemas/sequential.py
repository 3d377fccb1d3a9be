"""POST /v1/map and POST /v1/design/sequential: a module as a one-dimensional map, and a module
designed for a map feature, chained (zeromode.solver.sequential; arXiv 1906.08400)."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import BaseModel, Field, FiniteFloat, PositiveFloat

from zeromode.service.wire.schemas.common import FrameModel, RequestModel, ResultFrame

Pair = Annotated[list[int], Field(min_length=2, max_length=2)]


class ModuleModel(RequestModel):
    frame: FrameModel = Field(description="A frame with exactly one nontrivial zero mode.")
    input_pair: Pair = Field(description="Nodes [a, b]: d_in = |x_a − x_b| (not a bar).")
    output_pair: Pair = Field(description="Nodes [c, e]: d_out = |x_c − x_e| (not a bar).")


class MapRequest(ModuleModel):
    at: list[PositiveFloat] = Field(
        default_factory=list, max_length=1000,
        description="Input distances at which f and f′ are evaluated exactly (each inside the usable range).",
    )


class MapEndModel(BaseModel):
    kind: Literal["fold", "singular_point", "horizon"] = Field(
        description="fold: d_in turns back (f′ = ±∞); singular_point: the motion meets one; horizon: none within the search."
    )
    d_in: float
    d_out: float


class FixedPointModel(BaseModel):
    d: float = Field(description="d* = f(d*).")
    slope: float = Field(description="f′(d*).")
    stable: bool = Field(description="|f′(d*)| < 1: orbits near d* converge to it.")


class MapPointModel(BaseModel):
    d_in: float
    d_out: float = Field(description="f(d_in), exact (Newton on the module's branch).")
    slope: float = Field(description="f′(d_in) from the module's tangent.")


class MapBody(BaseModel):
    input_pair: list[int]
    output_pair: list[int]
    d_in: list[float] = Field(description="Samples of the branch through the reference, increasing.")
    d_out: list[float] = Field(description="f at each sample.")
    slope: list[float] = Field(description="f′ at each sample (from the null space of C there).")
    lower: MapEndModel = Field(description="The usable range's lower end.")
    upper: MapEndModel = Field(description="The usable range's upper end.")
    fixed_points: list[FixedPointModel]
    evaluated: list[MapPointModel] = Field(description="f and f′ at the requested `at`.")
    max_relative_bar_error: float = Field(description="Largest bar-length error along the traced motion.")


class MapResponse(MapBody):
    frame: ResultFrame = Field(description="The module's frame as given: the answer draws and exports the module beside its map.")
    timings_ms: dict[str, float]


class FixedPointFeature(RequestModel):
    kind: Literal["fixed_point"]
    d: PositiveFloat = Field(description="d* with f(d*) = d*.")
    slope: FiniteFloat = Field(description="f′(d*): |slope| < 1 stable, > 1 unstable.")


class PeriodTwoFeature(RequestModel):
    kind: Literal["period_two"]
    d1: PositiveFloat
    d2: PositiveFloat = Field(description="f(d1) = d2 and f(d2) = d1, d1 ≠ d2.")


class RangeFeature(RequestModel):
    kind: Literal["range"]
    source: Annotated[list[PositiveFloat], Field(min_length=2, max_length=2)] = Field(description="[a, b].")
    target: Annotated[list[PositiveFloat], Field(min_length=2, max_length=2)] = Field(
        description="[c, e]: f(a) = c and f(b) = e, f continuous and fold-free between."
    )


Feature = Annotated[FixedPointFeature | PeriodTwoFeature | RangeFeature, Field(discriminator="kind")]


class ChainOptions(RequestModel):
    n_modules: int = Field(default=16, ge=1, le=256, description="Copies chained (output pair of one = input pair of the next).")
    d0: PositiveFloat | None = Field(
        default=None, description="d_in of the first copy (default: the first feature's first input distance)."
    )


class SolitonOptions(RequestModel):
    n_modules: int = Field(default=16, ge=4, le=256, description="Copies chained; the wall travels over at least n_modules − 2 of them.")
    stiffness: PositiveFloat = Field(default=1.0, le=1e6, description="k of each copy's spring: E = Σ k (ℓ − L)²/2.")


class SequentialRequest(RequestModel):
    features: list[Feature] = Field(min_length=1, max_length=4, description="Map features, met together by one module.")
    start: ModuleModel | None = Field(
        default=None, description="The module whose node positions are optimised (default: the two-triangle module)."
    )
    chain: ChainOptions | None = Field(default=None, description="Chain the designed module and verify it by continuation.")
    soliton: SolitonOptions | None = Field(
        default=None,
        description="Instead of `chain`: a soliton. The features must be two fixed points, one unstable (slope > 1) and one "
                    "stable (slope in (0, 1)); one spring per copy makes both uniform states zero-energy minima, and the "
                    "domain wall between them travels along the chain as the input is driven.",
    )
    reach: PositiveFloat = Field(default=3.0, le=100.0, description="Nodes stay within reach × the start's RMS radius of its centre.")


class DesignedModule(BaseModel):
    frame: ResultFrame
    input_pair: list[int]
    output_pair: list[int]


class FeaturePointModel(BaseModel):
    d_in: float
    d_out: float = Field(description="Requested f(d_in).")
    slope: float | None = Field(description="Requested f′(d_in) (None: free).")
    achieved_d_out: float = Field(description="f(d_in) of the designed module, exact.")
    achieved_slope: float = Field(description="f′(d_in) of the designed module.")


class ChainBody(BaseModel):
    frame: ResultFrame = Field(description="The chained frame at the orbit from d0.")
    pairs: list[list[int]] = Field(description="(n + 1) node pairs: pair k is copy k's input, the last the last output.")
    iterates: list[float] = Field(description="d_0 … d_n the chain was built with: d_{k+1} = f(d_k).")
    distances: list[list[float]] = Field(description="d_k of every pair at each sample of the chain's traced motion.")
    path: list[list[list[float]]] = Field(
        description="The chain's conformation (every node, N_chain × 2) at each of those samples, in the same order: "
        "its motion as the input pair is driven (d_0 = distances[s][0]); aligned to `frame` by the best rigid motion."
    )
    reference_index: int = Field(description="The sample that is `frame` (the chain as built, at the orbit from d0).")
    deviation: float = Field(description="max |d_{k+1} − f(d_k)| / d_{k+1} over the traced motion (≤ map_rtol).")
    iterate_deviation: float = Field(
        description="max |d_k − f^k(d_0)| / d_k: grows like Π|f′| (amplified round-off at an unstable fixed point); reported, not promised."
    )
    ends: list[str] = Field(description="Why the traced motion ended each way: map_range, singular_point or horizon.")


class SpringModel(BaseModel):
    pairs: list[tuple[int, int]] = Field(description="One spring per copy [anchor, node] (chain node indices); never a rod.")
    stiffness: list[float] = Field(description="k of each spring.")
    rest_length: list[float] = Field(description="L: E = Σ k (|x_i − x_j| − L)²/2, zero in both uniform states.")


class UniformStateModel(BaseModel):
    d: float = Field(description="The fixed point every copy sits at.")
    slope: float = Field(description="f′ there.")
    energy: float = Field(description="E of the springs (0 up to round-off: every spring at its rest length).")
    hessian_min_eigenvalue: float = Field(
        description="Smallest eigenvalue of the full energy's Hessian (rods as stiff springs) modulo rigid motions: > 0, a strict minimum."
    )
    positions: list[list[float]] = Field(description="The chain's nodes in this state.")


class SolitonBody(BaseModel):
    module: DesignedModule = Field(description="The designed module with its spring anchor (the last node, a dyad on `anchor_bar`).")
    anchor_bar: list[int] = Field(description="The module's bar whose ends hold the anchor.")
    spring_node: int = Field(description="The module's node the spring joins to the anchor.")
    springs: SpringModel
    unstable: UniformStateModel = Field(description="Every copy at the unstable fixed point d_u.")
    stable: UniformStateModel = Field(description="Every copy at the stable fixed point d_s.")
    drive: list[float] = Field(description="d_0 at each sample of the verified motion strictly between d_u and d_s, from d_u.")
    rows: list[int] = Field(description="Each drive sample's row in chain.distances and chain.path.")
    wall: list[float | None] = Field(
        description="The domain wall: the fractional index k where (d_k − d_u)/(d_s − d_u) crosses ½ (null: the chain is on one side)."
    )
    wall_point: list[list[float] | None] = Field(
        description="The wall on the chain at each drive sample, [x, y] in chain.path[rows[i]]: the pairs' midpoints "
                    "interpolated at the fractional index w (pair k's and pair k + 1's by w − k; null with the wall)."
    )
    energy: list[float] = Field(description="E of the springs at each drive sample.")
    travel: float = Field(description="How many modules the wall moves over the drive.")
    required_travel: float = Field(description="The promise: travel ≥ n_modules − 2, monotonically.")
    wall_slope: float = Field(description="dw/d ln|d_0 − d_u| fitted where 1 ≤ w ≤ n − 1.")
    predicted_wall_slope: float = Field(description="−1/ln f′(d_u), the linearised prediction.")
    barrier: float = Field(description="The largest E along the drive (the wall's energy) above the uniform states' 0.")
    stiffness: float
    rod_stiffness_ratio: float = Field(description="K/k of the rods as stiff springs in the Hessian check.")
    snapshots: list[int] = Field(
        description="Drive indices whose wall is nearest k·n/5, k = 1…4 (the chain there: chain.path[rows[i]])."
    )


class SequentialResponse(BaseModel):
    module: DesignedModule
    map: MapBody
    features: list[FeaturePointModel]
    chain: ChainBody | None
    soliton: SolitonBody | None = Field(default=None, description="With `soliton`: the drive, the wall and the energy, verified.")
    deviation: float = Field(description="max relative deviation of the features (≤ map_rtol).")
    map_rtol: float = Field(description="The promise: features and chain within this.")
    solver_status: str = Field(description="IPOPT's return status (the answer is verified by continuation, not by it).")
    timings_ms: dict[str, float]


# Named examples of POST /v1/design/sequential (its OpenAPI examples; docs/module_maps.md).
SEQUENTIAL_EXAMPLES = {
    "deployable": {
        "summary": "Deployable chain",
        "description": "An unstable fixed point 1.2 (f′ = 1.8) and a stable one 1.8 (f′ = 0.4): "
                       "a 1 % change at the input opens the far end of the chain.",
        "value": {"features": [{"kind": "fixed_point", "d": 1.2, "slope": 1.8},
                               {"kind": "fixed_point", "d": 1.8, "slope": 0.4}],
                  "chain": {"n_modules": 16, "d0": 1.21}},
    },
    "curvature": {
        "summary": "Chain that changes its curvature",
        "description": "A marginal fixed point 1.3 (f′ = 1): near it f is close to the identity, so "
                       "every copy opens alike and the chain's curvature changes along its motion.",
        "value": {"features": [{"kind": "fixed_point", "d": 1.3, "slope": 1.0}],
                  "chain": {"n_modules": 12}},
    },
    "period_two": {
        "summary": "Period-2 chain",
        "description": "f(1.3) = 1.7 and f(1.7) = 1.3: the copies alternate.",
        "value": {"features": [{"kind": "period_two", "d1": 1.3, "d2": 1.7}], "chain": {"n_modules": 12}},
    },
    "soliton": {
        "summary": "Soliton",
        "description": "The deployable map (d_u = 1.2 unstable, f′ = 1.8; d_s = 1.8 stable, f′ = 0.4) with one spring "
                       "per copy: both uniform states are zero-energy minima, and as the input is driven from 1.8 "
                       "towards 1.2 the wall between closed and open copies travels the whole chain.",
        "value": {"features": [{"kind": "fixed_point", "d": 1.2, "slope": 1.8},
                               {"kind": "fixed_point", "d": 1.8, "slope": 0.4}],
                  "soliton": {"n_modules": 16}},
    },
    "stable_fixed_point": {
        "summary": "Stable fixed point",
        "description": "d* = 1.5 with f′ = −0.5: a disturbance at the input dies out along the chain, alternating.",
        "value": {"features": [{"kind": "fixed_point", "d": 1.5, "slope": -0.5}], "chain": {"n_modules": 12}},
    },
}
