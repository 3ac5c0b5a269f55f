"""Where a kernel's first compile goes: every function numba compiles for it, cold.

Compiles one :class:`roverimpact._kernels._jit.Kernel` in a fresh process with an empty
``NUMBA_CACHE_DIR`` (after a trivial compile that pays numba's one-off set-up) and records
numba's ``numba:compile`` events: per function and signature, the time of its compile
including the functions it calls (``total``) and without them (``self``: typing, lowering
and LLVM's optimisation of its own module, which links and optimises again the code of
the functions it calls). The shares are of the kernel's whole compile. A function that
another kernel already compiled into the same cache is loaded, not compiled, and is not
listed: ``--after impact`` compiles the unilateral impact kernel first (as a command
that runs the frictionless problem before the frictional one does).

Run: ``python benchmarks/bench_compile_breakdown.py [--kernel friction] [--after impact]``

2026-11-29, the shared 2-core machine under a load of 5.8 (other jobs; its loop of 1e6
additions 83 ms): the frictional kernel 67 s alone, 43 compiles, one signature each. Its
own module 35 s (52 %: typing, lowering and LLVM's optimisation of the 600-line kernel
with the code of every function it calls linked in), ``_mode_iteration`` 9.0 s, the
frictionless ``scaled_lcp`` 10.7 s with its ``lemke`` and ``nnls_lcp`` (16 %: loaded from
the cache when the impact kernel compiled them first, ``--after impact``),
``_frictional_lcp`` 6.5 s with its Lemke helpers, ``_held_energy`` 1.3 s. Turning LLVM's
loop vectoriser off for the kernel changed nothing beyond the noise (101 s and 95 s at a
load of 6).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

from machine import reference

ROOT = Path(__file__).resolve().parents[1]
KERNELS = {
    "friction": ("roverimpact._kernels.friction", "friction_kernel"),
    "impact": ("roverimpact._kernels.lemke", "impact_kernel"),
    "partition": ("roverimpact._kernels.partition", "partition_kernel"),
}

_CODE = """
import importlib, json, sys, time
import numba
numba.njit(lambda x: x + 1)(1.0)          # numba's one-off set-up, not the kernel's
from numba.core import event as ev
mod, attr, record = sys.argv[1], sys.argv[2], sys.argv[3] == "1"
kernel = getattr(importlib.import_module(mod), attr)
rec = ev.RecordingListener()
if record:
    ev.register("numba:compile", rec)
t = time.perf_counter()
kernel.get()
total = time.perf_counter() - t
events = [(ts, e.is_start, e.data["dispatcher"].py_func.__qualname__, str(e.data["args"]))
          for ts, e in rec.buffer]
print(json.dumps({"total": total, "events": events}))
"""


def _compile(name: str, cache: str, record: bool) -> dict:
    mod, attr = KERNELS[name]
    env = {"NUMBA_CACHE_DIR": cache, "PYTHONPATH": str(ROOT / "src")}
    out = subprocess.run([sys.executable, "-c", _CODE, mod, attr, "1" if record else "0"],
                         capture_output=True, text=True, check=True,
                         env={**os.environ, **env})
    return json.loads(out.stdout.strip().splitlines()[-1])


def breakdown(events) -> list[tuple[str, str, float, float]]:
    """(function, signature, total, self) per compile, from the nested start/end events."""
    stack, rows = [], []
    for ts, start, fn, sig in events:
        if start:
            stack.append([fn, sig, ts, 0.0])
            continue
        fn0, sig0, t0, children = stack.pop()
        total = ts - t0
        rows.append((fn0, sig0, total, total - children))
        if stack:
            stack[-1][3] += total
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--kernel", default="friction", choices=sorted(KERNELS))
    ap.add_argument("--after", choices=sorted(KERNELS), default=None,
                    help="compile this kernel first into the same cache")
    args = ap.parse_args()
    print(reference())
    with tempfile.TemporaryDirectory(prefix="ri-cold-") as cache:
        if args.after:
            first = _compile(args.after, cache, False)
            print(f"{args.after} kernel first: {first['total']:.1f} s")
        res = _compile(args.kernel, cache, True)
    rows = breakdown(res["events"])
    whole = res["total"]
    print(f"{args.kernel} kernel, cold: {whole:.1f} s; {len(rows)} compiles")
    print(f"{'self s':>7} {'share':>6} {'total s':>8}  function (signature)")
    for fn, sig, total, own in sorted(rows, key=lambda r: -r[3]):
        if own < 0.05:
            continue
        print(f"{own:7.2f} {100 * own / whole:5.1f}% {total:8.2f}  {fn} {sig[:60]}")


if __name__ == "__main__":
    main()
