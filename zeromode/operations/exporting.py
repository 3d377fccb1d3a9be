"""What POST /v1/export and ``zeromode export`` write: a document (documents.py) read into a
zeromode.export Takeaway — its frame, modes, sites, states, springs and report — with its finite
motion traced (solver.finite_motion, as POST /v1/motion does) when a motion format needs one and
the document carries none, and its fabrication tolerances (solver.tolerance) in the metadata when
asked, then written by zeromode.export.

A multistable design exports its rods as the frame and its springs as springs (their own element
type in every format), each conformation as a configuration ``conformation_<c>`` and, for the
motion formats, the conformations in turn as the path (parameter: each minimum's arc length s
along the motion; placed as the design gives them, not re-posed). A sequential design exports its
chain (or, without one, its module): its rods, the input pair as source and the last output
pair as target, and for the motion formats the chain's verified motion as it comes
(``chain.path``, time: the input distance d_0 of each sample; not traced again); a soliton's
springs (one per copy) as springs, and its two uniform states as configurations ``unstable`` and
``stable``. A /v1/map answer (a request answered first) exports its module: the input pair as
source, the output pair as target, the map in the metadata (``map``), which the map formats
(map_csv, map_svg, map_png) write.
"""

from __future__ import annotations

from zeromode.export import FORMATS, AnimationOptions, Fabrication, check_writable, export_bytes
from zeromode.export.takeaway import SpringSet, Takeaway
from zeromode.operations import endpoints
from zeromode.operations.documents import (
    ALLOSTERIC,
    AUXETIC,
    FRAME,
    MAP,
    MOTION,
    MULTISTABLE,
    SEQUENTIAL,
    AllostericDocument,
    AuxeticDocument,
    DesignDocument,
    MapDocument,
    MultistableDocument,
    PathDocument,
    SequentialDocument,
    is_map_request,
    kind,
    validated,
)
from zeromode.service.wire.convert import frame_from_model
from zeromode.service.wire.responses import json_safe, tolerance_body
from zeromode.service.wire.schemas.export import ExportRequest
from zeromode.solver.certificates.fabrication import tolerance_report
from zeromode.solver.errors import InvalidInput
from zeromode.solver.motion.finite_motion import trace_motion

# The export format a file's suffix names (``zeromode export``, the library's ``export``); .svg
# is a cut file or an animation: the format says which.
EXPORT_SUFFIXES = {
    ".vtu": "vtk", ".xdmf": "xdmf", ".graphml": "graphml", ".json": "node_link_json", ".dxf": "dxf",
    ".stl": "stl", ".csv": "kit_csv", ".gif": "gif", ".mp4": "mp4",
}
# A /v1/map answer's suffixes name its map formats instead.
MAP_SUFFIXES = {".csv": "map_csv", ".svg": "map_svg", ".png": "map_png"}


def format_for_suffix(suffix: str, doc) -> str | None:
    """The export format a file's suffix names for a document (``zeromode export``, the library's
    ``export``): EXPORT_SUFFIXES, but a /v1/map request or response writes its map as .csv, .svg
    and .png (MAP_SUFFIXES); None when the suffix names none."""
    suffix = suffix.lower()
    is_map = isinstance(doc, dict) and (kind(doc) == MAP or is_map_request(doc))
    return (MAP_SUFFIXES.get(suffix) if is_map else None) or EXPORT_SUFFIXES.get(suffix)


def export_file(request: ExportRequest) -> tuple[bytes, str, str]:
    """(content, media type, file name) of the export the request asks for."""
    check_writable(request.format)  # before the document is designed or its motion traced
    fmt = FORMATS[request.format]
    takeaway = takeaway_for(request)
    f, a = request.fabrication, request.animation
    content = export_bytes(
        takeaway,
        request.format,
        Fabrication(f.mm_per_unit, f.pin_diameter_mm, f.link_width_mm, f.thickness_mm, f.sheet_width_mm, f.gap_mm),
        AnimationOptions(a.frames, a.fps, a.scale, a.title),
    )
    return content, fmt.media_type, f"zeromode-{takeaway.metadata['kind']}{fmt.suffix}"


def takeaway_for(request: ExportRequest) -> Takeaway:
    """The request's document (designed first when it is a request) with the request's own
    frame, modes, path and springs taking precedence; the path traced when the format needs one
    and the document carries none (a chain carries its own: ``chain.path``). A /v1/map request
    is answered first (endpoints.map_answer)."""
    doc = endpoints.map_answer(request.document) or request.document or {}
    if doc and "frame" not in doc and kind(doc) not in (MOTION, SEQUENTIAL, MAP):
        doc, _ = endpoints.respond(doc)
    what = kind(doc) if doc else FRAME
    metadata: dict = {"kind": what}
    if isinstance(doc.get("report"), dict):
        metadata["report"] = doc["report"]
    sites, configurations, boundary, springs, placed, chained = {}, {}, None, None, None, None
    frame_model = validated(doc, DesignDocument).frame if "frame" in doc else None
    if what == MAP:
        the_map = validated(doc, MapDocument)
        sites = {"source": the_map.input_pair, "target": the_map.output_pair}
        metadata["map"] = the_map.model_dump(exclude={"frame"})
    elif what == SEQUENTIAL:
        sequential = validated(doc, SequentialDocument)
        chain, module = sequential.chain, sequential.module
        frame_model = (chain or module).frame
        pairs = chain.pairs if chain else [module.input_pair, module.output_pair]
        sites = {"source": pairs[0], "target": pairs[-1]}
        metadata["report"] = {"deviation": sequential.deviation, "map_rtol": sequential.map_rtol}
        if chain:
            metadata["report"]["chain"] = {"deviation": chain.deviation, "iterate_deviation": chain.iterate_deviation}
            metadata["chain"] = {"pairs": chain.pairs, "iterates": chain.iterates}
            # the verified motion, each sample at its input distance d_0
            chained = chain.path, [row[0] for row in chain.distances], chain.reference_index
        if sequential.soliton is not None:
            springs = sequential.soliton.springs
            states = {"unstable": sequential.soliton.unstable, "stable": sequential.soliton.stable}
            configurations = {name: state.positions for name, state in states.items() if state is not None}
    elif what == MULTISTABLE:
        multistable = validated(doc, MultistableDocument)
        springs = multistable.springs
        configurations = {f"conformation_{c}": x for c, x in enumerate(multistable.conformations)}
        if multistable.minima:
            metadata["minima"] = [m.model_dump() for m in multistable.minima]
            # minima name their conformation: a branched design's branch point is none of them
            placed = [multistable.conformations[m.index] for m in multistable.minima], [m.arclength for m in multistable.minima]
    frame_model = request.frame or frame_model
    if frame_model is None:
        raise InvalidInput("invalid_request", "the export needs a frame: give `frame`, or a document with one.")
    frame = frame_from_model(frame_model)
    springs = request.springs or springs
    modes = request.modes if request.modes is not None else (doc.get("modes") or [])
    if what == ALLOSTERIC:
        report = validated(doc, AllostericDocument).report
        sites = {"source": report.source, "target": report.target, "relays": report.relays}
    elif what == AUXETIC:
        lattice = validated(doc, AuxeticDocument)
        metadata["poisson_ratio"] = lattice.poisson_ratio
        configurations = {state.name: state.positions for state in lattice.states}
        boundary = lattice.report.boundary
    if request.tolerance is not None:
        tolerance = tolerance_report(
            frame, modes, boundary=boundary, source=sites.get("source", ()), target=sites.get("target", ()),
            **request.tolerance.model_dump(),
        )
        metadata["tolerance"] = tolerance_body(tolerance)
    elif metadata.get("report", {}).get("tolerance"):
        metadata["tolerance"] = metadata["report"]["tolerance"]
    path, parameter, reference = None, None, None
    if request.path is not None:
        path, parameter = request.path, request.parameter
    elif placed is not None:
        path, parameter = placed
    elif chained is not None:
        path, parameter, reference = chained
    elif "path" in doc:
        traced = validated(doc, PathDocument)
        path, parameter, reference = traced.path, traced.parameter, traced.reference_index
    elif FORMATS[request.format].motion:
        m = request.motion
        if modes and m.mode >= len(modes):
            raise InvalidInput("invalid_options", f"motion.mode is {m.mode}; the document has {len(modes)} mode(s).")
        motion = trace_motion(
            frame, mode=modes[m.mode] if modes else None, amplitude=m.amplitude, max_step=m.max_step
        )
        path, parameter, reference = motion.positions, motion.parameter, motion.reference_index
        metadata["motion"] = {
            "status": motion.status,
            "max_relative_bar_error": motion.max_relative_bar_error,
            "singularities": len(motion.singularities),
        }
    return Takeaway.build(
        frame, modes, path, parameter, reference, configurations, **sites, metadata=json_safe(metadata),
        springs=None if springs is None else SpringSet(springs.pairs, springs.stiffness, springs.rest_length),
        align=placed is None or request.path is not None,
    )
