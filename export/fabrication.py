"""Fabrication: the frame as parts to cut or print, in millimetres.

Every bar becomes a *link*: a flat plate of width w with rounded ends (a stadium) and a pin hole
of diameter p at each end, the holes' centres exactly the bar's length apart (times the scale,
``mm_per_unit``). Links are laid flat on a sheet in rows, longest first, each engraved with
"i-j L" (its nodes and its pin-to-pin length in mm), so the kit assembles by matching node
numbers. Holes are exact circles in DXF; pins need the clearance the machine needs (give p
accordingly).

Springs (a multistable design's) are not links: each is laid out after the links, in rows of
its own, as its two pin holes its *rest length* apart (times the scale) joined by a line — the
template to cut a band or set a coil to — engraved "i-j L k=k_s", on layers of their own.

  dxf      ezdxf: layer CUT (link outlines and holes, red), ENGRAVE (link labels), SPRING (spring
           holes and lines, blue), SPRING_ENGRAVE (spring labels); units mm
  cut_svg  the same drawing rendered by ezdxf's SVG backend, in mm, white page, no legend
  stl      the links as printable plates of thickness t, laid out as on the sheet, one closed
           triangle mesh each (written by meshio, binary STL); springs are not printed
  kit_csv  the parts list of a strut-and-hub kit (KIT_COLUMNS): each bar with its nodes and
           length in the frame's units and in mm, then each spring with its nodes, rest length
           (frame units and mm) and stiffness

The scale defaults to DEFAULT_SHORTEST_LINK_WIDTHS link widths for the shortest bar.
"""

from __future__ import annotations

import csv
import io
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from zeromode.export.takeaway import Takeaway
from zeromode.solver.errors import InvalidInput

DEFAULT_SHORTEST_LINK_WIDTHS = 5.0
# Label height as a fraction of the link width: legible, and inside the plate.
LABEL_HEIGHT = 0.4
# Straight edge of a half link and each half circle of a hole or end are this many segments in
# the STL (a 48-gon circle is within 0.3 % of the circle's area).
ARC_SEGMENTS, EDGE_SEGMENTS = 24, 8


@dataclass(frozen=True)
class Fabrication:
    """Physical sizes in mm. mm_per_unit: the scale (None: the shortest bar becomes
    DEFAULT_SHORTEST_LINK_WIDTHS link widths); pin_diameter, link_width, thickness (STL plates);
    sheet_width: rows of links are at most this wide; gap between parts."""

    mm_per_unit: float | None = None
    pin_diameter: float = 3.0
    link_width: float = 8.0
    thickness: float = 3.0
    sheet_width: float = 300.0
    gap: float = 3.0

    def scale(self, lengths: np.ndarray) -> float:
        """mm per frame unit; InvalidInput when the parts cannot be made (a hole wider than
        its link, or a bar shorter than the link is wide)."""
        if not self.pin_diameter < self.link_width:
            raise InvalidInput(
                "invalid_options",
                f"the pin diameter ({self.pin_diameter:g} mm) must be smaller than the link width ({self.link_width:g} mm).",
            )
        shortest = float(lengths.min()) if len(lengths) else 1.0
        scale = self.mm_per_unit or DEFAULT_SHORTEST_LINK_WIDTHS * self.link_width / shortest
        if len(lengths) and not shortest * scale >= self.link_width:
            b = int(np.argmin(lengths))
            raise InvalidInput(
                "invalid_options",
                f"bar {b} would be {shortest * scale:.3g} mm long, shorter than the link width "
                f"({self.link_width:g} mm): raise mm_per_unit or narrow the links.",
            )
        return scale


@dataclass(frozen=True, eq=False)
class Sheet:
    """Links laid flat: pins (N_B, 2, 2), the two hole centres of each bar in mm (the first
    at node i, the second at node j), labels (N_B,); springs after them: spring_pins (S, 2, 2)
    their hole centres, rest length apart, spring_labels (S,); the sheet's size (width,
    height) in mm."""

    pins: np.ndarray
    labels: tuple[str, ...]
    size: tuple[float, float]
    scale: float
    spring_pins: np.ndarray
    spring_labels: tuple[str, ...]


def sheet(takeaway: Takeaway, fab: Fabrication) -> Sheet:
    """Rows of links, longest first, left to right and bottom to top; a row is at most
    sheet_width wide (a link longer than that gets a row of its own). The springs follow in
    rows of their own, laid out alike by their rest lengths."""
    scale = fab.scale(takeaway.lengths)
    mm = takeaway.lengths * scale
    rest_mm = takeaway.springs.rest_length * scale
    pitch = fab.link_width + fab.gap  # centre-to-centre distance of rows
    pins, top, width = _rows(mm, fab, 0.0)
    spring_pins, top, spring_width = _rows(rest_mm, fab, top + pitch if len(mm) and len(rest_mm) else top)
    height = top + fab.link_width if len(mm) or len(rest_mm) else 0.0
    labels = tuple(f"{i}-{j} {m:.1f}" for (i, j), m in zip(takeaway.frame.edges.tolist(), mm))
    spring_labels = tuple(
        f"{i}-{j} {m:.1f} k={k:.4g}"
        for (i, j), m, k in zip(takeaway.springs.pairs.tolist(), rest_mm, takeaway.springs.stiffness)
    )
    return Sheet(pins, labels, (max(width, spring_width), height), scale, spring_pins, spring_labels)


def _rows(mm: np.ndarray, fab: Fabrication, y: float) -> tuple[np.ndarray, float, float]:
    """Parts whose holes are ``mm`` apart in rows from height ``y`` (the bottom of the first
    row), longest first: their hole centres (P, 2, 2), the bottom of the last row, the width."""
    pitch = fab.link_width + fab.gap  # centre-to-centre distance of rows
    pins = np.zeros((len(mm), 2, 2))
    x = width = 0.0
    for b in np.argsort(-mm, kind="stable"):
        footprint = mm[b] + fab.link_width  # pin-to-pin plus the two rounded ends
        if x > 0 and x + footprint > fab.sheet_width:
            x, y = 0.0, y + pitch
        left = x + fab.link_width / 2
        pins[b] = [[left, y + fab.link_width / 2], [left + mm[b], y + fab.link_width / 2]]
        x += footprint + fab.gap
        width = max(width, x - fab.gap)
    return pins, y, width


# ----------------------------------------------------------------------------- DXF and SVG


def dxf_document(takeaway: Takeaway, fab: Fabrication):
    """An ezdxf document of the sheet: per link a closed LWPOLYLINE outline (two half circles
    as bulges of 1) and two CIRCLE holes on layer CUT, a centred TEXT label on layer ENGRAVE;
    per spring two CIRCLE holes and the LINE between their centres on layer SPRING, a TEXT
    label on SPRING_ENGRAVE; header units mm; the metadata, sizes and number of springs as
    custom header properties."""
    import ezdxf
    from ezdxf.enums import TextEntityAlignment

    layout = sheet(takeaway, fab)
    doc = ezdxf.new("R2010")
    doc.units = ezdxf.units.MM
    doc.layers.add("CUT", color=1)
    doc.layers.add("ENGRAVE", color=7)
    doc.layers.add("SPRING", color=5)
    doc.layers.add("SPRING_ENGRAVE", color=7)
    msp = doc.modelspace()
    r_end, r_pin = fab.link_width / 2, fab.pin_diameter / 2
    height = LABEL_HEIGHT * fab.link_width
    for (a, b), label in zip(layout.pins, layout.labels):
        (x0, y0), (x1, _) = a, b
        outline = [(x0, y0 - r_end, 0.0), (x1, y0 - r_end, 1.0), (x1, y0 + r_end, 0.0), (x0, y0 + r_end, 1.0)]
        msp.add_lwpolyline(outline, format="xyb", close=True, dxfattribs={"layer": "CUT"})
        for centre in (a, b):
            msp.add_circle(tuple(centre), r_pin, dxfattribs={"layer": "CUT"})
        text = msp.add_text(label, height=height, dxfattribs={"layer": "ENGRAVE"})
        text.set_placement(((x0 + x1) / 2, y0), align=TextEntityAlignment.MIDDLE_CENTER)
    for (a, b), label in zip(layout.spring_pins, layout.spring_labels):
        for centre in (a, b):
            msp.add_circle(tuple(centre), r_pin, dxfattribs={"layer": "SPRING"})
        msp.add_line(tuple(a), tuple(b), dxfattribs={"layer": "SPRING"})
        text = msp.add_text(label, height=height, dxfattribs={"layer": "SPRING_ENGRAVE"})
        text.set_placement(((a[0] + b[0]) / 2, a[1] + r_end), align=TextEntityAlignment.TOP_CENTER)
    properties = {
        "zeromode.mm_per_unit": f"{layout.scale:.12g}",
        "zeromode.pin_diameter_mm": f"{fab.pin_diameter:g}",
        "zeromode.link_width_mm": f"{fab.link_width:g}",
        "zeromode.springs": str(len(layout.spring_pins)),
        "zeromode.metadata": json.dumps(dict(takeaway.metadata)),
        **({"zeromode.tolerance": takeaway.metadata["tolerance"]["summary"]} if takeaway.metadata.get("tolerance") else {}),
    }
    for tag, value in properties.items():
        doc.header.custom_vars.append(tag, value)
    return doc


def dxf_bytes(takeaway: Takeaway, fab: Fabrication) -> bytes:
    buffer = io.StringIO()
    dxf_document(takeaway, fab).write(buffer)
    return buffer.getvalue().encode()


def cut_svg_bytes(takeaway: Takeaway, fab: Fabrication) -> bytes:
    """The DXF drawn by ezdxf's SVG backend at 1:1 in mm: cuts red and labels black on white,
    no legend (labels become filled glyph outlines, for engraving)."""
    from ezdxf.addons.drawing import Frontend, RenderContext, config, layout, svg

    doc = dxf_document(takeaway, fab)
    ensure_fonts()
    backend = svg.SVGBackend()
    settings = config.Configuration(
        background_policy=config.BackgroundPolicy.WHITE, color_policy=config.ColorPolicy.COLOR
    )
    Frontend(RenderContext(doc), backend, config=settings).draw_layout(doc.modelspace())
    page = layout.Page(0, 0, layout.Units.mm, margins=layout.Margins.all(fab.gap))
    return backend.get_string(page, settings=layout.Settings(fit_page=False, scale=1)).encode()


def ensure_fonts() -> None:
    """ezdxf draws text with the TrueType fonts it finds on the system; where there are none (a
    slim container) it would draw no labels, so it is given matplotlib's DejaVu fonts, which ship
    inside matplotlib's wheel."""
    import matplotlib
    from ezdxf.fonts import fonts

    if not fonts.font_manager.has_font("DejaVuSans.ttf"):
        fonts.font_manager.build([str(Path(matplotlib.get_data_path()) / "fonts" / "ttf")], support_dirs=False)


# ----------------------------------------------------------------------------- STL


def link_mesh(length: float, width: float, pin_diameter: float, thickness: float) -> tuple[np.ndarray, np.ndarray]:
    """One link as a closed triangle mesh: vertices (V, 3) and triangles (F, 3), counter-clockwise seen from outside.

    Pins at (0, 0) and (length, 0). The plate's face is a ring around each pin: its inner loop
    the hole, its outer loop the half circle of the link's end on the far side and, on the near
    side, the half rectangle up to the midline x = length/2, met by rays from the pin (the half
    rectangle is star-shaped from the pin, so the quads between consecutive rays never overlap).
    The two rings share their midline vertices; the face is extruded to ``thickness`` and walled
    along the edges that only one face triangle uses.
    """
    big, small = width / 2, pin_diameter / 2
    half = length / 2
    # The near side of the pin at the origin: the half rectangle's boundary, bottom → midline → top.
    bottom = np.column_stack([np.linspace(0, half, EDGE_SEGMENTS + 1), np.full(EDGE_SEGMENTS + 1, -big)])
    midline = np.column_stack([np.full(2 * EDGE_SEGMENTS + 1, half), np.linspace(-big, big, 2 * EDGE_SEGMENTS + 1)])
    near = np.vstack([bottom, midline[1:], bottom[::-1][1:] * [1, -1]])
    angles = np.linspace(np.pi / 2, 3 * np.pi / 2, ARC_SEGMENTS + 1)[1:-1]
    far = big * np.column_stack([np.cos(angles), np.sin(angles)])
    outer = np.vstack([near, far])  # counter-clockwise around the pin
    inner = small * outer / np.linalg.norm(outer, axis=1, keepdims=True)
    # The second ring is the first reflected in the midline (x → length − x), order reversed to
    # stay counter-clockwise.
    mirror = np.array([length, 0.0]) + outer[::-1] * [-1, 1]
    rings = [(outer, inner), (mirror, np.array([length, 0.0]) + inner[::-1] * [-1, 1])]
    points: dict[tuple[float, float], int] = {}
    verts: list[tuple[float, float]] = []

    def index(p) -> int:
        key = (round(float(p[0]), 9), round(float(p[1]), 9))  # shared midline vertices coincide
        if key not in points:
            points[key] = len(verts)
            verts.append(key)
        return points[key]

    face = []
    for out, inn in rings:
        o = [index(p) for p in out]
        h = [index(p) for p in inn]
        n = len(o)
        for k in range(n):
            a, b = k, (k + 1) % n
            face += [(h[a], h[b], o[b]), (h[a], o[b], o[a])]
    xy = np.array(verts)
    face = np.array(face)
    u, v = xy[face[:, 1]] - xy[face[:, 0]], xy[face[:, 2]] - xy[face[:, 0]]
    area = u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]  # twice the signed area
    face[area < 0] = face[area < 0][:, ::-1]  # every face triangle counter-clockwise (normal +z)
    nv = len(xy)
    vertices = np.vstack([np.column_stack([xy, np.zeros(nv)]), np.column_stack([xy, np.full(nv, thickness)])])
    triangles = [face[:, ::-1], face + nv]  # bottom faces down, top faces up
    edges: dict[tuple[int, int], int] = {}
    for tri in face:
        for a, b in ((tri[0], tri[1]), (tri[1], tri[2]), (tri[2], tri[0])):
            key = (min(a, b), max(a, b))
            edges[key] = edges.get(key, 0) + 1
    walls = []
    for tri in face:
        for a, b in ((tri[0], tri[1]), (tri[1], tri[2]), (tri[2], tri[0])):
            if edges[(min(a, b), max(a, b))] == 1:  # a boundary edge, interior on its left
                walls += [(a, b, b + nv), (a, b + nv, a + nv)]
    triangles.append(np.array(walls))
    return vertices, np.vstack(triangles)


def stl_bytes(takeaway: Takeaway, fab: Fabrication) -> bytes:
    """Every link as a plate (link_mesh), placed where the sheet lays it, as one binary STL."""
    import meshio

    from zeromode.export.meshes import written_bytes

    layout = sheet(takeaway, fab)
    vertices, triangles, offset = [], [], 0
    for a, b in layout.pins:
        v, t = link_mesh(float(np.linalg.norm(b - a)), fab.link_width, fab.pin_diameter, fab.thickness)
        vertices.append(v + [a[0], a[1], 0.0])
        triangles.append(t + offset)
        offset += len(v)
    mesh = meshio.Mesh(np.vstack(vertices), [("triangle", np.vstack(triangles))])
    return written_bytes(lambda path: meshio.write(path, mesh, file_format="stl", binary=True), ".stl")


# ----------------------------------------------------------------------------- kit list


# The kit list's columns: a bar's first five (``kind`` "rod"), a spring's ``kind`` "spring", its
# index ``spring``, nodes, rest length in frame units and mm, and stiffness; the other
# cells are empty, so a spring row never reads as a bar (its ``bar`` and ``length`` are blank).
KIT_COLUMNS = ("bar", "node_i", "node_j", "length", "length_mm", "kind", "spring", "rest_length", "rest_length_mm", "stiffness")


def kit_csv_bytes(takeaway: Takeaway, fab: Fabrication) -> bytes:
    """The parts list (KIT_COLUMNS): the bars, then the springs, after ``#`` comment lines with
    the counts, the scale and the metadata (JSON)."""
    lengths = takeaway.lengths
    scale = fab.scale(lengths)
    springs = takeaway.springs
    out = io.StringIO()
    out.write(
        f"# zeromode strut-and-hub kit: {takeaway.frame.n_nodes} hubs, {takeaway.frame.n_edges} struts, "
        f"{len(springs.pairs)} springs\n"
    )
    out.write(f"# mm_per_unit: {scale:.12g}\n")
    if takeaway.metadata.get("tolerance"):
        out.write(f"# tolerance: {takeaway.metadata['tolerance']['summary']}\n")
    out.write(f"# metadata: {json.dumps(dict(takeaway.metadata))}\n")
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(KIT_COLUMNS)
    for b, ((i, j), length) in enumerate(zip(takeaway.frame.edges.tolist(), lengths)):
        writer.writerow([b, i, j, f"{length:.12g}", f"{length * scale:.6f}", "rod", "", "", "", ""])
    for s, ((i, j), rest, k) in enumerate(zip(springs.pairs.tolist(), springs.rest_length, springs.stiffness)):
        writer.writerow(["", i, j, "", "", "spring", s, f"{rest:.12g}", f"{rest * scale:.6f}", f"{k:.12g}"])
    return out.getvalue().encode()
