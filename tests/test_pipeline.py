"""The pipeline (solver/pipeline.py): stages run only when asked, and one analysis is reused.

The count is taken by wrapping the real ``analyze`` where each stage looks it up (a spy, not a
mock: every call still runs the real analysis). The results are checked independently: the
designed mode is a zero mode of C built here from its definition, and the refined frame keeps
its bar lengths along IPOPT's path.
"""

import numpy as np
import pytest

import zeromode.solver.certificates as certificates_module
import zeromode.solver.design as design_module
import zeromode.solver.refine as refine_module
from zeromode.solver.pipeline import RefineStage, design_pipeline
from zeromode.solver.rigidity import analyze as real_analyze

SQUARE = [[1.0, 1.0], [-1.0, 1.0], [-1.0, -1.0], [1.0, -1.0]]
OUTWARD = [[1.0, 1.0], [-1.0, 1.0], [-1.0, -1.0], [1.0, -1.0]]


@pytest.fixture
def analyses(monkeypatch):
    """Every call of the rigidity analysis made by the stages, as (n_nodes, bases) pairs."""
    calls = []

    def spy(frame, *args, **kwargs):
        calls.append((frame.n_nodes, kwargs.get("bases", True)))
        return real_analyze(frame, *args, **kwargs)

    for module in (design_module, refine_module, certificates_module):
        monkeypatch.setattr(module, "analyze", spy)
    return calls


def compatibility_oracle(x, edges):
    """C from its definition (paper Eq. 3), dense, independent of zeromode's builder."""
    n, d = x.shape
    c = np.zeros((len(edges), n * d))
    for row, (i, j) in enumerate(edges):
        c[row, d * i : d * i + d] = x[i] - x[j]
        c[row, d * j : d * j + d] = x[j] - x[i]
    return c


def test_design_alone_runs_one_analysis_and_no_other_stage(analyses):
    result = design_pipeline(SQUARE, [OUTWARD], dim=2)
    assert result.refinement is None and result.certificate is None
    assert set(result.timings_ms) == {"design", "total"}
    assert analyses == [(result.design.frame.n_nodes, True)]
    frame = result.design.frame
    c = compatibility_oracle(frame.positions, frame.edges)
    u = result.design.modes[0].ravel()
    assert np.linalg.norm(c @ u) <= 1e-10 * np.linalg.norm(c) * np.linalg.norm(u)


def test_design_refine_certify_runs_the_full_analysis_at_most_twice(analyses):
    result = design_pipeline(
        SQUARE, [OUTWARD], dim=2, refine_stage=RefineStage(amplitude=0.1), certify_stage=True
    )
    full = [call for call in analyses if call[1]]
    assert 1 <= len(full) <= 2, analyses
    assert result.refinement is not None and result.refinement.ok
    assert result.certificate is not None
    assert set(result.timings_ms) == {"design", "refine", "certify", "total"}
    # The refined frame's bars keep their lengths along IPOPT's path (computed here).
    path, edges = result.refinement.path, result.refinement.frame.edges
    lengths = np.linalg.norm(path[:, edges[:, 0]] - path[:, edges[:, 1]], axis=2)
    assert np.max(np.abs(lengths / lengths[0] - 1)) <= 1e-6
    # The certificate speaks of the linear design, whose counts the oracle confirms.
    frame = result.design.frame
    rank = np.linalg.matrix_rank(compatibility_oracle(frame.positions, frame.edges))
    assert result.certificate.analysis.rank == rank
    assert result.certificate.analysis.self_stresses == frame.n_edges - rank == 0


def test_refinement_of_several_motions_is_refused_before_any_analysis(analyses):
    from zeromode.solver.errors import InvalidInput

    second = [[1.0, 0.0], [1.0, 0.0], [-1.0, 0.0], [-1.0, 0.0]]
    with pytest.raises(InvalidInput) as err:
        design_pipeline(SQUARE, [OUTWARD, second], dim=2, refine_stage=RefineStage())
    assert err.value.code == "invalid_options"
    assert analyses == []
