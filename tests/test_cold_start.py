"""A fresh environment: the kernels compile off the requests' budgets, once, and once per cache.

solver/analysis/compiled.py: the time a thread spends in numba's compiler lock is not charged to its time
budget (checked against numba's own timer of that lock, its event API); the kernels are compiled
for one set of argument types (a Frame's read-only arrays add no specialisation after
rigidity.warm_up); processes sharing a cache warm up in turn (a second one waits on the first's
lock). The service side (``/health``'s ``kernels``, requests served while the kernels compile on
a cold cache) is tested cold by tests/container.
"""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
from numba import njit, types
from numba.core import event

from zeromode.solver.analysis import sparse_kernels
from zeromode.solver.analysis.compiled import compiling_alone
from zeromode.solver.analysis.normalisation import _normalised
from zeromode.solver.analysis.rigidity import analyze, warm_up
from zeromode.solver.budget import _DEADLINE, time_budget
from zeromode.solver.frame import Frame


def test_compilation_is_not_charged_to_the_budget():
    """A function compiled inside a budget moves its deadline by exactly the time numba's timer
    saw its compiler lock held (two listeners of the same events: equal to their own overhead)."""
    spans = []

    @njit
    def fresh(x):  # never compiled before: no cache, a new function object
        return np.sum(np.sqrt(np.abs(x)))

    with time_budget(60.0):
        before = _DEADLINE.get()[0]
        with event.install_timer("numba:compiler_lock", spans.append):
            fresh(np.arange(3.0))
        moved = _DEADLINE.get()[0] - before
    assert sum(spans) > 0.0
    assert abs(moved - sum(spans)) <= 0.05 * sum(spans) + 1e-3, (moved, spans)
    with time_budget(60.0):  # compiled now: nothing more is charged off
        before = _DEADLINE.get()[0]
        fresh(np.arange(3.0))
        assert _DEADLINE.get()[0] == before


def test_frames_read_only_arrays_add_no_specialisation_after_warm_up():
    """rigidity.warm_up compiles each kernel for the one set of types analyses pass: a built
    Frame (read-only positions and bars) on both routes, with and without bases, in 2D and 3D,
    compiles nothing new, and no kernel is compiled for a read-only array (numba's type for it
    differs: every kernel would compile twice)."""
    warm_up()
    kernels = [getattr(sparse_kernels, name) for name in dir(sparse_kernels)] + [_normalised]
    kernels = [k for k in kernels if hasattr(k, "overloads")]
    before = {k: len(k.overloads) for k in kernels}
    rng = np.random.default_rng(0)
    for d in (2, 3):
        x = rng.standard_normal((12, d))
        bars = [(i, j) for i in range(12) for j in range(i + 1, 12) if (i + j) % 3 == 0]
        frame = Frame.build(x, bars)
        assert not frame.positions.flags.writeable and not frame.edges.flags.writeable
        for method in ("dense", "sparse"):
            for bases in (False, True):
                dense = analyze(frame, method="dense", bases=bases)
                counted = analyze(frame, method=method, bases=bases)
                assert (counted.rank, counted.self_stresses) == (dense.rank, dense.self_stresses)
    after = {k: len(k.overloads) for k in kernels}
    assert after == before, {k.__name__: (before[k], after[k]) for k in kernels if after[k] != before[k]}
    read_only = [(k.__name__, sig) for k in kernels for sig in k.overloads
                 if any(isinstance(t, types.Array) and not t.mutable for t in sig)]
    assert not read_only, read_only


def test_a_second_process_warms_up_after_the_first_lets_go():
    """While this process holds the warm-up lock of the cache, another process's warm_up waits
    (it has not finished two seconds after it reached the lock, where a warm cache loads in 0.2 s);
    once released, it finishes."""
    script = (
        "import sys\n"
        "from zeromode.solver.analysis.rigidity import warm_up\n"
        "print('ready', flush=True)\n"
        "warm_up()\n"
        "print('done', flush=True)\n"
    )
    with compiling_alone(sparse_kernels.null_space_rounds):
        proc = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True, env=os.environ)
        try:
            assert proc.stdout.readline().strip() == "ready"
            try:
                proc.wait(timeout=2.0)
            except subprocess.TimeoutExpired:
                pass
            assert proc.poll() is None, "warm_up ran while another process held the lock"
        except BaseException:
            proc.kill()
            raise
    assert proc.communicate(timeout=300)[0].strip() == "done"
    assert proc.returncode == 0
