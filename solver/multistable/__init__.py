"""Multistable networks of rods and springs (issue #41, item 1): a one-degree-of-freedom
linkage through two or three conformations (``linkage``), springs making each a strict energy
minimum along its motion (``springs``), and their independent verification (``verify``)."""
