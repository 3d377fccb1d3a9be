"""Motion: following a designed zero mode to finite amplitude.

``finite_motion`` continues the frame along its mode keeping every bar length (the nonlinear
counterpart of C·u = 0); ``periodic`` does it one cell at a time for tiled frames; ``refine``
moves the unspecified nodes (casadi/IPOPT) so the finite path follows the prescribed motions;
``target`` stops the motion at a requested distance, angle, strain or fraction;
``boundary_strain`` measures a motion by the strains ε_x, ε_y of a frame's boundary node sets and
its Poisson ratio ν = −ε_y/ε_x.
"""
