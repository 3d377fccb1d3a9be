"""Construction: judicious constraint placement (paper, Eqs. 4–6 and "Multi-Mode Construction").

An unspecified node joined to the specified nodes lies on their ``solution_space`` (a linear
system plus one quadric, Eqs. 4–6); ``placement`` picks points on it so that the prescribed
motions are the only nontrivial zero modes; ``multimode`` intersects the spaces of several
motions (Fig. 4); ``hierarchical_pairs`` and ``hierarchical_placement`` go past the bipartite
bound (Discussion); ``coupling`` merges modules (Fig. 5); ``two_configuration`` designs a frame
with equal bar lengths in two conformations; ``design`` validates, builds and verifies.
"""
