"""Shared test setup.

zeromode's numerics are many small dense problems; a multi-threaded BLAS only contends on the
2-core CI machine, so tests run single-threaded like the service (set before numpy loads).
"""

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")
