"""Graph formats through networkx: node-link JSON and GraphML.

The frame is an undirected graph: node i carries its position (``x``, ``y`` and, in 3D, ``z``),
``role`` ("specified" or "unspecified"), ``site`` (Takeaway.SITES), the components of each
zero mode (``mode<m>_x``, ``mode<m>_y``, …) and its position in each named configuration
(``<name>_x``, …: a lattice's states, a multistable design's conformations ``conformation_<c>``).
Every edge carries ``kind``: a rod (i, j) ("rod") its ``length`` and its index ``bar``; a
spring ("spring") its ``length`` in the reference, ``rest_length`` L_s, ``stiffness`` k_s and its
index ``spring`` (no pair is both: Takeaway.build refuses it). The graph carries the metadata:
nested JSON in node-link JSON, a JSON string in GraphML (whose attributes are scalars).
"""

from __future__ import annotations

import io
import json

import networkx as nx

from zeromode.export.takeaway import SITES, Takeaway

AXES = "xyz"


def frame_graph(takeaway: Takeaway, nested_metadata: bool) -> nx.Graph:
    """The frame as a networkx Graph with the attributes of the module docstring."""
    frame = takeaway.frame
    graph = nx.Graph()
    graph.graph["dim"] = frame.dim
    metadata = dict(takeaway.metadata)
    graph.graph["metadata"] = metadata if nested_metadata else json.dumps(metadata)
    specified, sites = takeaway.specified_mask, takeaway.sites
    for i, x in enumerate(frame.positions):
        attrs = {AXES[a]: float(x[a]) for a in range(frame.dim)}
        attrs["role"] = "specified" if specified[i] else "unspecified"
        attrs["site"] = SITES[sites[i]]
        for m, mode in enumerate(takeaway.modes):
            attrs.update({f"mode{m}_{AXES[a]}": float(mode[i, a]) for a in range(frame.dim)})
        for name, config in takeaway.configurations.items():
            attrs.update({f"{name}_{AXES[a]}": float(config[i, a]) for a in range(frame.dim)})
        graph.add_node(i, **attrs)
    for b, ((i, j), length) in enumerate(zip(frame.edges.tolist(), takeaway.lengths)):
        graph.add_edge(i, j, kind="rod", length=float(length), bar=b)
    springs = takeaway.springs
    for s, ((i, j), length) in enumerate(zip(springs.pairs.tolist(), takeaway.spring_lengths)):
        graph.add_edge(i, j, kind="spring", length=float(length), rest_length=float(springs.rest_length[s]),
                       stiffness=float(springs.stiffness[s]), spring=s)
    return graph


def node_link_bytes(takeaway: Takeaway) -> bytes:
    """networkx's node-link JSON (``nx.node_link_graph(json.load(f))`` reads it back)."""
    data = nx.node_link_data(frame_graph(takeaway, nested_metadata=True), edges="edges")
    return json.dumps(data, allow_nan=False).encode()


def graphml_bytes(takeaway: Takeaway) -> bytes:
    """GraphML (``nx.read_graphml`` reads it back; node ids become strings there)."""
    buffer = io.BytesIO()
    nx.write_graphml(frame_graph(takeaway, nested_metadata=False), buffer)
    return buffer.getvalue()
