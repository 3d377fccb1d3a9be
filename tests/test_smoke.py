from zeromode.solver import Frame, analyze


def test_triangle_is_rigid():
    a = analyze(Frame.build([[0, 0], [1, 0], [0, 1]], [[0, 1], [1, 2], [0, 2]]))
    assert (a.rank, a.zero_modes, a.nontrivial_zero_modes, a.self_stresses) == (3, 3, 0, 0)
