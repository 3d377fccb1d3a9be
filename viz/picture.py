"""What a picture shows, validated: a frame and what is drawn with it (modes, requested motions,
solution spaces, further configurations, text, markers, the view).

``Picture.build`` checks raw input (lists from JSON or arrays) against the frame and raises
InvalidInput naming the first bad field; everything downstream (layout, writers) trusts it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from zeromode.solver.errors import InvalidInput
from zeromode.solver.frame import Frame, check_positions
from zeromode.viz.style import VIEW_3D


@dataclass(frozen=True, eq=False)
class Picture:
    """A frame and what to draw with it.

    modes (M, N, d): zero modes, solid arrows on ``arrow_nodes`` (None: every node, or a spread
    subsample of a frame with more than style.MAX_ARROW_NODES nodes); targets (M', k, d):
    requested motions u_S, hollow arrows, rows in the order of frame.specified (a zero row draws
    nothing); solution_space: draw the solution space of every requested motion (targets, or
    else the modes' rows on the specified nodes), sampled with ``seed`` where it is a cloud;
    configurations (C, N, d): further positions of the same bars, drawn at one common scale
    beside the frame, whose panel is number ``frame_panel`` among the 1 + C; labels / captions:
    text above / below each panel, in panel order; source / target_nodes: node indices marked
    with a purple square / an orange diamond (allosteric frames); view: (azimuth, elevation) in
    degrees of a 3D frame; title above the picture.
    """

    frame: Frame
    modes: np.ndarray
    targets: np.ndarray
    configurations: np.ndarray
    solution_space: bool = False
    labels: tuple[str, ...] = ()
    captions: tuple[str, ...] = ()
    source: tuple[int, ...] = ()
    target_nodes: tuple[int, ...] = ()
    arrow_nodes: tuple[int, ...] | None = None
    frame_panel: int = 0
    view: tuple[float, float] = VIEW_3D
    title: str | None = None
    seed: int = 0

    @classmethod
    def build(
        cls,
        frame: Frame,
        modes=None,
        targets=None,
        solution_space: bool = False,
        configurations=None,
        labels=None,
        captions=None,
        source=(),
        target_nodes=(),
        arrow_nodes=None,
        frame_panel: int = 0,
        view: tuple[float, float] = VIEW_3D,
        title: str | None = None,
        seed: int = 0,
    ) -> Picture:
        """Validate raw input against the frame (see the class); raises InvalidInput with code
        invalid_shape, invalid_targets, invalid_nodes, invalid_labels, invalid_captions,
        invalid_frame_panel or no_motion."""
        n, d, k = frame.n_nodes, frame.dim, len(frame.specified)
        mode_arr = stacked(modes, n, d, "modes", "the frame's nodes")
        if targets is not None and len(targets) and k == 0:
            raise InvalidInput("invalid_targets", "targets need specified nodes in the frame (specified is empty).")
        target_arr = stacked(targets, k, d, "targets", "the specified nodes")
        configs = stacked(configurations, n, d, "configurations", "the frame's nodes")
        node_lists = [("source", source), ("target_nodes", target_nodes)]
        if arrow_nodes is not None:
            node_lists.append(("arrow_nodes", arrow_nodes))
        for name, nodes in node_lists:
            _check_nodes(name, nodes, n)
        n_panels = 1 + len(configs)
        labels, captions = tuple(labels or ()), tuple(captions or ())
        for name, texts in (("labels", labels), ("captions", captions)):
            if len(texts) > n_panels:
                raise InvalidInput(
                    f"invalid_{name}", f"{len(texts)} {name} for {n_panels} panels (the frame and its configurations)."
                )
        if isinstance(frame_panel, bool) or not isinstance(frame_panel, (int, np.integer)) or not 0 <= frame_panel < n_panels:
            raise InvalidInput("invalid_frame_panel", f"frame_panel must be a panel index in 0..{n_panels - 1}.")
        if solution_space and (k == 0 or not (len(target_arr) or len(mode_arr))):
            raise InvalidInput(
                "no_motion", "solution_space needs specified nodes and a motion (targets or modes) to draw."
            )
        return cls(
            frame, mode_arr, target_arr, configs, bool(solution_space), labels, captions,
            tuple(int(i) for i in source), tuple(int(i) for i in target_nodes),
            None if arrow_nodes is None else tuple(int(i) for i in arrow_nodes),
            int(frame_panel), (float(view[0]), float(view[1])), title, int(seed),
        )

    @property
    def motions(self) -> np.ndarray:
        """The requested motions u_S (M', k, d) whose solution spaces are drawn: the targets, or
        else the modes' rows on the specified nodes."""
        return self.targets if len(self.targets) else self.modes[:, list(self.frame.specified)]


def stacked(arrays, rows: int, d: int, name: str, what: str) -> np.ndarray:
    """A list of (rows × d) finite arrays as one (count, rows, d) array, or raise InvalidInput."""
    if arrays is None or not len(arrays):
        return np.zeros((0, rows, d))
    out = []
    for i, a in enumerate(arrays):
        a = check_positions(a, d, f"{name}[{i}]")
        if len(a) != rows:
            raise InvalidInput("invalid_shape", f"{name}[{i}] has {len(a)} rows; it needs one per node of {what} ({rows}).")
        out.append(a)
    return np.stack(out)


def _check_nodes(name: str, nodes, n: int) -> None:
    if not all(isinstance(i, (int, np.integer)) and not isinstance(i, bool) for i in nodes):
        raise InvalidInput("invalid_nodes", f"{name} must be a list of integer node indices.")
    bad = [i for i in nodes if not 0 <= i < n]
    if bad:
        raise InvalidInput("invalid_nodes", f"{name} names node {bad[0]}, outside 0..{n - 1}.")
    if len(set(nodes)) != len(nodes):
        raise InvalidInput("invalid_nodes", f"{name} lists a node more than once.")
