"""Analysis: the compatibility matrix C of a frame and its zero modes (paper, Eqs. 1–3).

C (b × d·n) maps node motions to bar extensions; its null space holds the zero modes, d(d+1)/2
of them rigid. ``rigidity`` counts and returns them (dense SVD or the sparse rank route of
``sparse_kernels``/``factorisation``/``compiled``), on the scale-normalised frame
(``normalisation``); ``rank`` holds the relative thresholds and the singular-value gap,
``eigen`` and ``bordered`` the stiffness-matrix eigenpairs and bordered systems used downstream.
"""
