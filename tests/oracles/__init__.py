"""The test suite's independent oracles, each written once.

Every expected value a test compares zeromode's answer with comes from here or from the test's
own derivation, never from zeromode itself: nothing in this package imports zeromode's solver
except the ``Frame`` type that the mechanism builders hand to the code under test.

- ``rigidity``: the compatibility matrix C from its definition (paper, Eq. 3), rigid motions
  written out, ranks and bases from numpy's full SVD; the list of count fields.
- ``pyrigi_adapter``: PyRigi's own rigidity matrix, flexes and stresses, behind one adapter.
- ``solution_space``: Ã, b (Eqs. 4–5), the quadric's block formula and the bar residuals (Eq. 1).
- ``motion``: bar lengths, rigid alignment, an independent continuation for the fidelity ε,
  and the Poisson ratio of a motion.
- ``frames``: small frames and targets whose answers are known by hand.
- ``mechanisms``: frames with one chosen zero mode, built from the paper's equations.
- ``designs``: everything a returned design promises, checked through the routes above.
- ``wire``: the JSON shapes of the REST contract (numbers, matrices, error bodies).

tests/ is on sys.path (tests/conftest.py), so tests import ``oracles.<module>``.
"""
