"""Which requests run on the job engine's worker processes rather than in the service's own.

A request is heavy (``heavy``) by its sizes, decided from what was measured inline on
a loaded 2-core machine (load 5-8): every request left inline answers in a few seconds at most
(its time budget, checked between its steps, is then never overrun by more than a step), e.g. an
auxetic sheet of 400 cells 0.5 s, a design of 32 nodes × 2 motions 3 s, an analysis of 300 2D
nodes 2.8 s at most; while an analysis of 1 000 floppy 2D nodes took 37 s, a 3D auxetic chain
of 8 blocks 60 s, a two-configuration design of 64 nodes 60 s, a plot or a GraphML export of
10⁵ nodes 20 s, a multistable design 1.5–2.5 s CPU when it succeeds and up to ~20 s when every
placement attempt is traced and fails (no_path).
"""

from __future__ import annotations

from typing import Any

# Requests whose answer can take long, by endpoint: the rest are cheap enough to answer inline.
ALWAYS = frozenset({"/v1/motion", "/v1/refine", "/v1/certify", "/v1/design/allosteric", "/v1/design/two-configuration",
                    "/v1/design/multistable", "/v1/design/sequential"})
# Above these sizes a frame's plot or export (nodes or bars), its analysis or a network's tuning
# (degrees of freedom dN or bars: a floppy frame's null-space bases cost seconds, 300 2D nodes up
# to 2.8 s, 1 000 up to 37 s), an auxetic sheet and a design (specified nodes × motions) are heavy.
HEAVY_NODES = 2_000
HEAVY_EDGES = 10_000
HEAVY_DOF = 600
HEAVY_CELLS = 400
HEAVY_DESIGN = 32
# The dense analysis asked for by name is heavy past this many rows or columns of C (≈ 0.5 s).
HEAVY_DENSE_SIDE = 1_000

def heavy(endpoint: str, request: dict[str, Any]) -> bool:
    """Whether the request should run on a worker process (see the module's docstring)."""
    if endpoint in ALWAYS:
        return True
    options = request.get("options") or {}
    frame = request.get("frame") or {}
    nodes = len(frame.get("positions") or [])
    edges = len(frame.get("edges") or [])
    large = nodes > HEAVY_NODES or edges > HEAVY_EDGES
    analysis = nodes * int(frame.get("dim") or 2) > HEAVY_DOF or edges > HEAVY_EDGES
    if endpoint == "/v1/design":
        return (len(request.get("positions") or []) * len(request.get("motions") or []) > HEAVY_DESIGN
                or any(options.get(stage) for stage in ("refine", "certify", "tolerance")))
    if endpoint == "/v1/design/auxetic":
        cells = request.get("cells") or [1]
        count = 1
        for c in cells:
            count *= int(c)
        return (request.get("dim") == 3 or count > HEAVY_CELLS
                or any(request.get(k) for k in ("refine", "certify", "finite_strain", "tolerance")))
    if endpoint == "/v1/analyze":
        dense = options.get("method") == "dense" and max(edges, nodes * int(frame.get("dim") or 2)) > HEAVY_DENSE_SIDE
        return analysis or dense
    if endpoint == "/v1/export":
        from zeromode.export import FORMATS

        fmt = FORMATS.get(request.get("format"))
        # a document may be a request (designed first); a motion format without a path is traced
        return bool(request.get("document") or request.get("tolerance")) or large or (
            fmt is not None and fmt.motion and request.get("path") is None)
    if endpoint == "/v1/design/allosteric/network":
        return analysis
    return large  # /v1/plot
