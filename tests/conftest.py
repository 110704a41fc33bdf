"""The suite's process setup: under pytest-xdist (addopts ``-n 2``), each worker's compiled and
BLAS thread pools get ``cores // workers`` threads (1 on CI's two cores), so that two workers
on two cores do not run four spinning threads (issue 39: the suite stays <= 10 min on 2
cores). Measured on two of the heaviest renderer files under ``-n 2``: 130 -> 108 CPU-s. A
serial run (``-n 0``) keeps every core. Variables already set by the user are kept; they are
read when numba, OpenMP and OpenBLAS start, which is after this file in a worker (child
processes that the tests start inherit them)."""
from __future__ import annotations

import os

_workers = int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "0") or 0)
if os.environ.get("PYTEST_XDIST_WORKER") and _workers > 1:
    _cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    _threads = str(max(1, (_cores or 1) // _workers))
    for _var in ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS",
                 "MKL_NUM_THREADS"):
        os.environ.setdefault(_var, _threads)
