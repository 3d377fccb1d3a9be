"""The pipeline (solver/pipeline.py): stages run only when asked, and one analysis is reused.

The count is taken by wrapping the real ``analyze`` where each stage looks it up (a spy, not a
mock: every call still runs the real analysis). The results are checked independently: the
designed mode is a zero mode of C built here from its definition, and the refined frame keeps
its bar lengths along IPOPT's path.
"""

import pytest
from oracles.frames import SQUARE_CORNERS
from oracles.motion import relative_bar_error
from oracles.rigidity import COUNT_FIELDS, compatibility_matrix, mode_residual, reference_counts

import zeromode.solver.certificates.prestress as certificates_module
import zeromode.solver.construction.design as design_module
import zeromode.solver.motion.refine as refine_module
from zeromode.solver.analysis.rigidity import analyze as real_analyze
from zeromode.solver.pipeline import RefineStage, design_pipeline

SQUARE = SQUARE_CORNERS
OUTWARD = SQUARE_CORNERS  # u_S = x_S: the corners move outward (paper, Fig. 3b)


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


def test_design_alone_runs_one_analysis_and_no_other_stage(analyses):
    result = design_pipeline(SQUARE, [OUTWARD], dim=2)
    assert result.refinement is None and result.certificate is None
    assert set(result.timings_ms) == {"design", "total"}
    assert analyses == [(result.design.frame.n_nodes, True)]
    frame = result.design.frame
    c = compatibility_matrix(frame.positions, frame.edges)
    assert mode_residual(c, result.design.modes[0]) <= 1e-10


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
    path = result.refinement.path
    assert relative_bar_error(path, result.refinement.frame.edges, path[0]) <= 1e-6
    # The certificate speaks of the linear design, whose counts the oracle confirms.
    frame = result.design.frame
    expected = reference_counts(frame.positions, frame.edges)
    assert {f: getattr(result.certificate.analysis, f) for f in COUNT_FIELDS} == expected
    assert expected["self_stresses"] == 0


def test_refinement_of_several_motions_is_refused_before_any_analysis(analyses):
    from zeromode.solver.errors import InvalidInput

    second = [[1.0, 0.0], [1.0, 0.0], [-1.0, 0.0], [-1.0, 0.0]]
    with pytest.raises(InvalidInput) as err:
        design_pipeline(SQUARE, [OUTWARD, second], dim=2, refine_stage=RefineStage())
    assert err.value.code == "invalid_options"
    assert analyses == []
