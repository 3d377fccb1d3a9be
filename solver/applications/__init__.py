"""Applications: the paper's targets built from modules (paper, Fig. 5 and Discussion).

``lattice`` and ``sheet_module`` tile auxetic sheets of a chosen Poisson ratio ν;
``finite_strain`` measures ν along the finite motion and ``strain_range`` finds where a sheet's
motion meets a collision or a turning point; ``allostery`` relays a source site's
motion to a distant target through a chain of modules; ``network_allostery`` edits a given
network so that its source drives its target.
"""
