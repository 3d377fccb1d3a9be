"""Modules as one-dimensional maps and sequential conformational change (Rocks, Kim, Bassett
et al., arXiv 1906.08400): a module's map d_out = f(d_in) from its finite motion
(module_map), a module designed for a requested map feature (design), and chains of modules
whose conformation is the orbit of f, verified by continuation (chain)."""
