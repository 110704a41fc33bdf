"""The Table 2 cell at N = 16 000 samples does not crash and reproduces its samples.

Run:  python bench/table2_cell_16000.py [--n 16000]

N = 16 000 is the size where bare OpenBLAS ``dpotrf`` segfaults on AVX-512 CPUs with two
threads (``theory/_cholesky.py``). The cell's interpolant (``SobolevInterpolator``, s = 1.5,
``solver="cholesky"``: envfit's blocked Cholesky) is built in a child process, so that a
crash is a clear failure, and must reproduce 300 of its samples to 1e-6, checked by the
direct kernel sum (which does not use the factor). ~100 s on two cores. The suite's
``tests/test_cholesky.py`` runs the same child at N = 5 000 (three 2048-column panels).
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from test_cholesky import _table2_cell_child  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=16000)
    n = ap.parse_args().n
    t = time.perf_counter()
    err = _table2_cell_child(n, Path.cwd())
    ok = err < 1e-6
    print(f"N = {n}: max |interpolant - sample| at 300 samples = {err:.3g} "
          f"({'ok' if ok else 'FAIL'}, < 1e-6), {time.perf_counter() - t:.0f} s")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
