"""A module's map as files (a /v1/map answer, carried by the Takeaway's metadata ``map``): the
sampled map as CSV, and the module beside its map as an SVG or PNG picture."""

from __future__ import annotations

import csv
import io

from zeromode.export.takeaway import Takeaway
from zeromode.solver.errors import InvalidInput

# The picture's resolution in PNG (matplotlib's dots per inch of a 10 × 5 inch figure).
MAP_PNG_DPI = 110


def map_body(takeaway: Takeaway, fmt: str) -> dict:
    """The /v1/map answer the takeaway carries; InvalidInput ``invalid_document`` when it carries
    none (a map format asked of another document)."""
    body = takeaway.metadata.get("map")
    if not isinstance(body, dict):
        raise InvalidInput(
            "invalid_document", f"{fmt} writes a module's map: give a /v1/map response or request as the document."
        )
    return body


def map_csv_bytes(takeaway: Takeaway) -> bytes:
    """One row per sample of the map's usable range, d_in increasing: ``d_in``, ``d_out`` = f(d_in)
    and ``slope`` = f′(d_in), each as Python writes a float (shortest round trip)."""
    body = map_body(takeaway, "map_csv")
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(["d_in", "d_out", "slope"])
    writer.writerows(zip(body["d_in"], body["d_out"], body["slope"]))
    return out.getvalue().encode()


def map_picture_bytes(takeaway: Takeaway, fmt: str) -> bytes:
    """The module (the takeaway's frame, its source and target the input and output pairs) beside
    its map f (viz.sequential.map_figure), as ``fmt`` "svg" or "png"."""
    from zeromode.viz.sequential import map_figure

    body = map_body(takeaway, f"map_{fmt}")
    buffer = io.BytesIO()
    map_figure(body, takeaway.frame).savefig(buffer, format=fmt, dpi=MAP_PNG_DPI)
    return buffer.getvalue()
