"""Client.design_multistable against the real service (uvicorn on loopback): the answer's rods
keep their lengths in every conformation and its springs' energy, recomputed here from the
definition, has a strict minimum at each conformation along the motion."""

from __future__ import annotations

import numpy as np
import pytest
from oracles.elastic import constrained_curvature
from oracles.motion import bar_lengths

from zeromode_client import Client, ZeromodeError

APEX = [[0.3, 0.8], [0.45, 1.0], [0.65, 1.15]]
CONFORMATIONS = [[[0.0, 0.0], [1.0, 0.0], p] for p in APEX]


def test_design_multistable(service_url: str) -> None:
    with Client(service_url, timeout=120.0) as client:
        result = client.design_multistable(dim=2, conformations=CONFORMATIONS)
        edges = np.asarray(result["frame"]["edges"])
        confs = result.array("conformations")
        lengths = [bar_lengths(c, edges) for c in confs]
        assert max(np.max(np.abs(ell - lengths[0]) / lengths[0]) for ell in lengths) <= 1e-12
        springs = result["springs"]
        pairs = np.asarray(springs["pairs"], dtype=int)
        for c in confs:
            kkt, curvature = constrained_curvature(c, edges, pairs, springs["stiffness"], springs["rest_length"])
            assert kkt <= 1e-7 and curvature > 0
        with pytest.raises(ZeromodeError) as err:
            client.design_multistable(dim=2, conformations=CONFORMATIONS, options={"barrier": 10.0})
        assert err.value.code == "no_springs"
