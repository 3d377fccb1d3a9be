"""zeromode.viz — pictures of frames in the paper's visual language.

Arrays in, pictures out; nothing here decides mathematics (the solver does: solution spaces,
rigid motions, strains come from zeromode.solver).

  style      colours, sizes and the rules that pick them
  geometry   the 3D view, arrow and marker outlines, spacing rules (numpy only)
  curves     solution spaces (paper Eqs. 4–6) traced as curves and point sets to draw
  picture    Picture: what to draw, validated against the frame
  designs    pictures of zeromode's results: a design, a lattice, an allosteric frame
  layout     Picture → Scene: shapes in pixels (scene.py)
  svg        Scene → SVG text
  raster     Scene → PNG or PDF (matplotlib, imported only when used)
"""
