"""ParaView's formats through meshio: VTK (.vtu) and XDMF (.xdmf, a time series).

The frame is a mesh of points (its nodes, padded to 3D with z = 0 for a planar frame) and
"line" cells: its rods (bars) first, then its springs, in one block. Point data: ``specified``
(1 on V_S), ``site`` (Takeaway.SITES: 0 none, 1 source, 2 target, 3 relay), each zero mode as a
vector field ``mode_<m>``, and each named configuration (a lattice's states, a multistable
design's conformations ``conformation_<c>``) as the displacement field ``<name>`` from the
reference. Cell data: ``kind`` (CELL_KINDS: 0 rod, 1 spring), ``length`` (in the reference),
``bar`` (the rod's index, −1 on a spring), ``spring`` (the spring's index, −1 on a rod),
``rest_length`` and ``stiffness`` (a spring's L_s and k_s; NaN on a rod, which has neither).

Rods and springs are one line block told apart by ``kind`` rather than two blocks: a .vtu file
holds one unstructured grid, whose cells have no block (meshio writes blocks one after the other
and reads contiguous cells of one type back as one block), so in ParaView the distinction has to
be a cell array — Threshold on ``kind`` (or Color By ``kind``) shows the springs alone, and
colouring them by ``stiffness`` or ``rest_length`` then spans the springs' range only (VTK's
ranges skip NaN). Field data: the metadata's numbers, one array each,
with dotted names (``report.analysis.rank``) — meshio 5.3's VTU writer drops field data, so its
<FieldData> block is added to the XML meshio wrote (meshio reads it back). An XDMF file holds the
finite motion as a time series (time = path parameter; a multistable design's conformations,
time = the arc length s of each minimum along the motion, so ParaView's time controls step from
minimum to minimum) whose point data ``displacement`` moves the nodes with ParaView's Warp By
Vector; its data are XML inside the file (one self-contained
file, no HDF5), and the metadata, as JSON, an <Information Name="zeromode"> of its Domain.
"""

from __future__ import annotations

import json
import tempfile
import xml.etree.ElementTree as ET
from pathlib import Path

import meshio
import numpy as np

from zeromode.export.takeaway import Takeaway

# Cell data ``kind``: the element type of each line cell.
CELL_KINDS = ("rod", "spring")


def vtu_bytes(takeaway: Takeaway) -> bytes:
    """The frame with its modes and configurations as a VTK unstructured grid (.vtu)."""
    mesh = meshio.Mesh(
        _points(takeaway.frame.positions),
        [("line", _lines(takeaway))],
        point_data=_point_data(takeaway),
        cell_data=_cell_data(takeaway),
    )
    vtu = ET.fromstring(written_bytes(lambda path: meshio.write(path, mesh, file_format="vtu"), ".vtu"))
    fields = ET.Element("FieldData")
    for name, value in _field_data(takeaway.metadata).items():
        array = ET.SubElement(fields, "DataArray", type="Float64", Name=name, NumberOfTuples="1", format="ascii")
        array.text = repr(float(value))
    vtu.find("UnstructuredGrid").insert(0, fields)
    return ET.tostring(vtu, xml_declaration=True, encoding="utf-8")


def xdmf_bytes(takeaway: Takeaway) -> bytes:
    """The finite motion as an XDMF time series: one step per configuration of the path (one
    step, the reference, when there is none), point data ``displacement`` from the reference
    beside the static fields of vtu_bytes."""
    x = takeaway.frame.positions
    path = takeaway.path if takeaway.path is not None else x[None]
    times = takeaway.parameter if takeaway.parameter is not None else np.zeros(1)
    static = _point_data(takeaway)

    def write(path_name: str) -> None:
        with meshio.xdmf.TimeSeriesWriter(path_name, data_format="XML") as writer:
            writer.write_points_cells(_points(x), [("line", _lines(takeaway))])
            for t, config in zip(times, path):
                writer.write_data(
                    float(t),
                    point_data={"displacement": _points(config - x), **static},
                    cell_data=_cell_data(takeaway),
                )

    xdmf = ET.fromstring(written_bytes(write, ".xdmf"))
    xdmf.find("Domain").insert(0, ET.Element("Information", Name="zeromode", Value=json.dumps(dict(takeaway.metadata))))
    return ET.tostring(xdmf, xml_declaration=True, encoding="utf-8")


def _points(x: np.ndarray) -> np.ndarray:
    """(N, 3): ParaView's points and vectors are 3D; a planar frame gets z = 0."""
    return np.column_stack([x, np.zeros((len(x), 3 - x.shape[1]))]) if x.shape[1] < 3 else np.asarray(x, float)


def _point_data(takeaway: Takeaway) -> dict[str, np.ndarray]:
    x = takeaway.frame.positions
    data = {
        "specified": takeaway.specified_mask.astype(np.int32),
        "site": takeaway.sites.astype(np.int32),
    }
    data.update({f"mode_{m}": _points(mode) for m, mode in enumerate(takeaway.modes)})
    data.update({name: _points(config - x) for name, config in takeaway.configurations.items()})
    return data


def _lines(takeaway: Takeaway) -> np.ndarray:
    """(N_B + S, 2): the rods, then the springs."""
    return np.vstack([takeaway.frame.edges, takeaway.springs.pairs]).astype(np.int64)


def _cell_data(takeaway: Takeaway) -> dict[str, list[np.ndarray]]:
    """The cell arrays of the module docstring, over the rods then the springs."""
    n_bars, springs = takeaway.frame.n_edges, takeaway.springs
    n_springs = len(springs.pairs)
    none = np.full(n_bars, np.nan)
    return {
        "kind": [np.repeat(np.arange(len(CELL_KINDS), dtype=np.int32), [n_bars, n_springs])],
        "length": [np.concatenate([takeaway.lengths, takeaway.spring_lengths])],
        "bar": [np.concatenate([np.arange(n_bars), np.full(n_springs, -1)]).astype(np.int32)],
        "spring": [np.concatenate([np.full(n_bars, -1), np.arange(n_springs)]).astype(np.int32)],
        "rest_length": [np.concatenate([none, springs.rest_length])],
        "stiffness": [np.concatenate([none, springs.stiffness])],
    }


def _field_data(metadata, prefix: str = "") -> dict[str, float]:
    """The numbers of a JSON-ready mapping, one per leaf, named by their dotted path."""
    out: dict[str, float] = {}
    for key, value in metadata.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            out.update(_field_data(value, name + "."))
        elif isinstance(value, int | float) and value is not None:
            out[name] = float(value)
    return out


def written_bytes(write, suffix: str) -> bytes:
    """The bytes meshio writes to a file (its writers take file names)."""
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / f"export{suffix}"
        write(str(path))
        return path.read_bytes()
