"""`python3 dev.py bench compiled`: the graph's hot kernels in numpy (the package's own functions) against one-pass
loops compiled with numba, on this machine's widest vector code and on AVX2 code, and what numba costs a process
at start. The package keeps numpy for a kernel unless the compiled loop is faster on both codes and its start cost
is repaid within a default run (the cycles of the built-in graph `python3 dev.py demo` runs: `default_run_cycles`).

Kernels, on one table1 frame (BATCH cycles of 64 x 1080 samples, the graph's frame), each checked against the
package's result on the same input before it is timed:

    adc      radar/adc.py adc_codes with an attack added: rint((rx + attack) / lsb) as int16 codes, rails and NaN/Inf
             counted per cycle; the compiled loop gives the same codes and counts (checked: equal)
    detector detect/detector.py chirp_rms_codes: every chirp's RMS from exact sums of squares of its int16 codes;
             the compiled loop sums in int64 (checked: equal)
    noise    radar/noise.py standard_normal_rows: Box-Muller on the generator's raw words, the same formulation in
             one loop (the words drawn by numpy in both); float32 log, cos and sin come from numpy's vector code on
             one side and from the C library (or Intel's SVML, when numba finds it) on the other, so the samples
             differ in their last bits: the largest difference is reported in float32 epsilons of each sample's
             magnitude

Targets: `native` (numba for this CPU, numpy's own dispatch) and, on a machine with AVX-512, `avx2` in a child
process: numba for Haswell (NUMBA_CPU_NAME=haswell) and numpy with its AVX-512 loops off (NPY_DISABLE_CPU_FEATURES),
what an AVX2 machine runs. Each kernel: --repeats rounds, numpy and numba alternated within each round, medians.

Start: a fresh process (numpy imported already, as in a node) imports numba and makes the first call of one
kernel's loop (a node runs one); its CPU time with an empty numba cache (compiles) and with a warm one (loads the
machine code), medians of --starts processes each. A node pays the warm cost at every start (the cold one once per
machine and numba version); break-even = the warm cost / what the loop saves a cycle on the slower target.
numba's loops call the C library's log, cos and sin one value at a time: the llvmlite wheels on PyPI are built
without Intel's SVML (`svml` in the records says whether numba found it).
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from bench import records as bench_records
from carav_stream.console.options import count, output_file
from carav_stream.core.allocator import keep_freed_memory
from carav_stream.detect.detector import chirp_rms_codes
from carav_stream.radar.adc import adc_codes, adc_step
from carav_stream.radar.noise import standard_normal_rows
from carav_stream.radar.noise import words as raw_words
from carav_stream.radar.scene_loader import load_scene
from carav_stream.runtime.loader import load_graph

ROOT = Path(__file__).resolve().parents[1]
KERNELS = ("adc", "detector", "noise")
BATCH = 32                    # cycles per frame (graphs/radar_chain.toml)
DEFAULT_GRAPH = ROOT / "graphs" / "demo.toml"     # what `python3 dev.py demo` runs
AVX2_ENV = {"NUMBA_CPU_NAME": "haswell", "NUMBA_CPU_FEATURES": "",
            "NPY_DISABLE_CPU_FEATURES": "X86_V4 AVX512_ICL AVX512_SPR"}


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--json", type=output_file, metavar="FILE", help="write the records as JSON to FILE")
    parser.add_argument("--repeats", type=count(1), default=15, help="alternated rounds per kernel (default 15)")
    parser.add_argument("--starts", type=count(1), default=3, help="fresh processes per start case (default 3)")
    parser.add_argument("--targets", default="native,avx2", help="comma-separated: native, avx2 (default both)")


# -- the compiled loops --------------------------------------------------------------------------------------------
def default_run_cycles() -> int:
    """The cycles of a default run: those of the graph `python3 dev.py demo` runs."""
    return int(load_graph(DEFAULT_GRAPH).run["cycles"])


def compiled_kernels() -> dict[str, Any]:
    """numba's one-pass loops (imported and compiled here, on first use; cached in numba's cache folder)."""
    import numba

    jit = numba.njit(cache=True, nogil=True)

    @jit
    def adc_loop(rx, add, scale, lo, hi, width, out, clipped, nonfinite):
        """rx (n, m) float32 values (I/Q: interleaved, `width` 2), add (1 | n, m); codes into out (n, m) int16;
        a sample (its `width` values) counts once as clipped or nonfinite, as adc_codes counts it. A cycle goes in
        one branch-free pass (vectorised) that also counts values off the rails or not finite; only a cycle with
        such values is gone over again, value by value."""
        n, m = rx.shape
        for c in range(n):
            a = 0 if add.shape[0] == 1 else c
            off = 0
            for k in range(m):
                v = np.rint((rx[c, k] + add[a, k]) * scale)
                off += not (v >= lo and v <= hi)               # NaN fails both
                out[c, k] = np.int16(min(max(v, lo), hi))
            n_clip = 0
            n_bad = 0
            if off:
                for s in range(0, m, width):
                    over = False
                    bad = False
                    for k in range(s, s + width):
                        v = np.rint((rx[c, k] + add[a, k]) * scale)
                        if not np.isfinite(v):
                            bad = True
                            out[c, k] = 0
                        elif v > hi or v < lo:
                            over = True
                    n_clip += over
                    n_bad += bad
            clipped[c] = n_clip
            nonfinite[c] = n_bad

    @jit
    def sumsq_loop(codes, out):
        """codes (rows, n) int16: every row's exact sum of squares (int64) into out float64."""
        for i in range(codes.shape[0]):
            s = np.int64(0)
            for j in range(codes.shape[1]):
                v = np.int64(codes[i, j])
                s += v * v
            out[i] = s

    @jit
    def box_muller_loop(u, v, k, out):
        """u, v (rows, h) uint32 and int32 (the two halves of each row's raw words); out (rows, n) float32."""
        u32 = np.float32(2.0 ** -32)
        half = np.float32(2.0 ** -33)
        angle = np.float32(2.0 * np.pi * 2.0 ** -32)
        rows, h = u.shape
        n = out.shape[1]
        for i in range(rows):
            for j in range(h):
                r = np.sqrt(np.log(np.float32(u[i, j]) * u32 + half) * k)
                theta = np.float32(v[i, j]) * angle
                out[i, j] = r * np.cos(theta)
                if h + j < n:
                    out[i, h + j] = r * np.sin(theta)

    return {"adc": adc_loop, "sumsq": sumsq_loop, "box_muller": box_muller_loop, "numba": numba}


def adc_compiled(kernels: dict, scene, rx: np.ndarray, add: np.ndarray, out: np.ndarray):
    """adc_codes(scene, rx, out, add=add) by the compiled loop: (codes, clipped, nonfinite)."""
    lsb = adc_step(scene)
    n = rx.shape[0]
    width = 2 if scene.iq else 1
    flat = rx.reshape(n, -1).view(np.float32)
    plus = add.reshape(add.shape[0], -1).view(np.float32)
    if plus.shape[1] != flat.shape[1]:          # an attack that broadcasts over chirps: spelled out per value
        plus = np.ascontiguousarray(np.broadcast_to(add, (add.shape[0],) + rx.shape[1:])).reshape(add.shape[0], -1)
        plus = plus.view(np.float32)
    clipped, nonfinite = np.zeros(n, np.int64), np.zeros(n, np.int64)
    kernels["adc"](flat, plus, np.float32(1.0 / lsb), np.float32(-(2 ** (scene.adc_bits - 1))),
                   np.float32(2 ** (scene.adc_bits - 1) - 1), width, out.reshape(n, -1), clipped, nonfinite)
    return out, clipped, nonfinite


def rms_compiled(kernels: dict, codes: np.ndarray, lsb: float, iq: bool) -> np.ndarray:
    """chirp_rms_codes(codes, lsb, iq) by the compiled loop."""
    lead = codes.shape[:2]
    n_samples = codes.shape[2]
    flat = codes.reshape(-1, n_samples * (2 if iq else 1))
    sumsq = np.empty(flat.shape[0])
    kernels["sumsq"](flat, sumsq)
    return float(lsb) * np.sqrt(sumsq / max(n_samples, 1)).reshape(lead)


def noise_compiled(kernels: dict, rng: np.random.Generator, n_rows: int, n_per_row: int, scale: float,
                   out: np.ndarray) -> np.ndarray:
    """standard_normal_rows(rng, n_rows, n_per_row, scale, out=out) by the compiled loop (same words, same steps)."""
    h = (n_per_row + 1) // 2
    words = raw_words(rng, n_rows * h).view(np.uint32).reshape(n_rows, 2 * h)   # as the package reads them
    k = np.float32(-2.0 * scale * scale)
    kernels["box_muller"](words[:, :h], words[:, h:].view(np.int32), k, out.reshape(n_rows, n_per_row))
    return out


# -- measuring -----------------------------------------------------------------------------------------------------
def _inputs(seed: int = 1) -> dict[str, Any]:
    """One table1 frame: receiver samples (noise at the ADC's design level and a car), an attack on every chirp of
    the first half of the cycles, the ADC codes of their sum."""
    scene = load_scene("table1")
    rng = np.random.default_rng(seed)
    lsb = adc_step(scene)
    sigma = lsb * 40.0                                    # noise RMS of 40 codes: the table1 receiver's design
    shape = (BATCH, scene.n_chirps, scene.n_samples)
    rx = (rng.standard_normal(shape, dtype=np.float32) * np.float32(sigma))
    rx += np.float32(sigma) * np.sin(np.arange(scene.n_samples, dtype=np.float32) * np.float32(0.3))
    add = np.zeros(shape, np.float32)
    add[: BATCH // 2] = rng.standard_normal((BATCH // 2,) + shape[1:], dtype=np.float32) * np.float32(3 * sigma)
    codes = adc_codes(scene, rx, add=add)[0]
    return {"scene": scene, "rx": rx, "add": add, "codes": codes, "lsb": lsb, "sigma": sigma}


def check(kernels: dict, data: dict) -> dict[str, float]:
    """Each compiled loop against the package's kernel on the same input: 0.0 when equal (adc, detector), the
    noise's largest difference in float32 epsilons of |z| (the inputs include rails and a NaN for the ADC)."""
    scene, rx, add = data["scene"], data["rx"].copy(), data["add"]
    rx[3, 5, 7] = np.nan
    rx[4, 2, :9] = 1e9                                     # rails, both signs
    rx[4, 3, :5] = -1e9
    a = adc_codes(scene, rx, add=add)
    b = adc_compiled(kernels, scene, rx, add, np.empty_like(data["codes"]))
    adc_equal = all(np.array_equal(x, y) for x, y in zip(a, b)) and a[1][4] == 14 and a[2][3] == 1
    rms_equal = np.array_equal(chirp_rms_codes(data["codes"], data["lsb"], False),
                               rms_compiled(kernels, data["codes"], data["lsb"], False))
    n = scene.n_chirps * scene.n_samples
    x = standard_normal_rows(np.random.default_rng(7), 4, n, 2.0)
    y = noise_compiled(kernels, np.random.default_rng(7), 4, n, 2.0, np.empty((4, n), np.float32))
    eps = float(np.finfo(np.float32).eps)
    noise_ulp = float(np.max(np.abs(x - y) / np.maximum(np.abs(x), np.float32(2.0 ** -20)))) / eps
    return {"adc": 0.0 if adc_equal else float("inf"), "detector": 0.0 if rms_equal else float("inf"),
            "noise": noise_ulp}


def time_kernels(kernels: dict, data: dict, repeats: int) -> dict[str, dict[str, float]]:
    """Seconds per frame, numpy and numba alternated round by round (a round: 3 calls of each), medians."""
    scene, rx, add, codes, lsb = data["scene"], data["rx"], data["add"], data["codes"], data["lsb"]
    out = np.empty_like(codes)
    n = scene.n_chirps * scene.n_samples
    noise_out = np.empty((BATCH, n), np.float32)
    rng = np.random.default_rng(3)
    pairs = {
        "adc": (lambda: adc_codes(scene, rx, out, add=add), lambda: adc_compiled(kernels, scene, rx, add, out)),
        "detector": (lambda: chirp_rms_codes(codes, lsb, False), lambda: rms_compiled(kernels, codes, lsb, False)),
        "noise": (lambda: standard_normal_rows(rng, BATCH, n, data["sigma"], out=noise_out),
                  lambda: noise_compiled(kernels, rng, BATCH, n, data["sigma"], noise_out)),
    }
    result = {}
    for name, fns in pairs.items():
        times: list[list[float]] = [[], []]
        for fn in fns:
            fn()                                            # warm: scratch, caches, first call
        for r in range(repeats):
            for side in ((0, 1) if r % 2 == 0 else (1, 0)):
                t0 = time.perf_counter()
                for _ in range(3):
                    fns[side]()
                times[side].append((time.perf_counter() - t0) / 3)
        result[name] = {"numpy_s": float(np.median(times[0])), "numba_s": float(np.median(times[1]))}
    return result


def child_kernels(repeats: int) -> dict[str, Any]:
    """What one target's process measures: the check, the timings, and what numpy and numba run on."""
    keep_freed_memory()
    kernels = compiled_kernels()
    numba = kernels["numba"]
    data = _inputs()
    from numpy._core._multiarray_umath import __cpu_features__ as features  # numpy's dispatch, as it stands
    off = os.environ.get("NPY_DISABLE_CPU_FEATURES", "").split()
    return {"check": check(kernels, data), "times": time_kernels(kernels, data, repeats),
            "numba": numba.__version__, "svml": bool(numba.config.USING_SVML),
            "numba_cpu": os.environ.get("NUMBA_CPU_NAME") or "host",
            "numpy_avx512": bool(features.get("AVX512_SKX")) and "X86_V4" not in off}


def child_start(kernel: str) -> dict[str, float]:
    """A fresh process's cost of numba for one kernel (a node runs one): import, then its loop's first call
    (compiled, or loaded from numba's cache)."""
    c0, w0 = time.process_time(), time.perf_counter()
    kernels = compiled_kernels()
    c1 = time.process_time()
    if kernel == "adc":
        rx = np.zeros((1, 2, 8), np.float32)
        adc_compiled(kernels, load_scene("table1"), rx, rx, np.empty((1, 2, 8), np.int16))
    elif kernel == "detector":
        rms_compiled(kernels, np.zeros((1, 2, 8), np.int16), 1.0, False)
    else:
        noise_compiled(kernels, np.random.default_rng(0), 1, 8, 1.0, np.empty((1, 8), np.float32))
    return {"cpu_s": time.process_time() - c0, "import_cpu_s": c1 - c0, "wall_s": time.perf_counter() - w0}


def _child(what: str, env: dict[str, str], arg: Any) -> dict[str, Any]:
    code = f"import json; from bench import compiled as c; print(json.dumps(c.child_{what}({arg!r})))"
    proc = subprocess.run([sys.executable, "-c", code], cwd=ROOT, env={**os.environ, **env},
                          capture_output=True, text=True)
    if proc.returncode:
        raise RuntimeError(f"bench compiled: the {what} process failed:\n{proc.stderr.strip()}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def run(args: argparse.Namespace) -> int:
    try:
        import numba  # noqa: F401  (here only to say so clearly when it is missing)
    except ImportError:
        print("dev.py bench compiled: numba is not installed (it comes with the bench extra: "
              "pip install -e '.[bench]')", file=sys.stderr)
        return 1
    targets = [t.strip() for t in args.targets.split(",") if t.strip()]
    unknown = set(targets) - {"native", "avx2"}
    if unknown:
        print(f"dev.py bench compiled: unknown targets {sorted(unknown)} (native, avx2)", file=sys.stderr)
        return 2
    scene = load_scene("table1")
    samples = scene.n_chirps * scene.n_samples
    print(bench_records.header())
    simd = bench_records.machine()["simd"]
    records: list[dict[str, Any]] = []
    with tempfile.TemporaryDirectory(prefix="carav-numba-") as cache:
        starts: dict[str, float] = {}          # warm cache: what a node pays at every start but the first
        for kernel in KERNELS:
            runs: dict[str, list[dict[str, float]]] = {"cold": [], "warm": []}
            for i in range(args.starts):    # cold: an empty cache each time; warm: the cache the cold one left
                env = {"NUMBA_CACHE_DIR": os.path.join(cache, f"{kernel}{i}")}
                runs["cold"].append(_child("start", env, kernel))
                runs["warm"].append(_child("start", env, kernel))
            for case, got in runs.items():
                records.append({"bench": "start", "kernel": kernel, "cache": case, "processes": len(got),
                                **{k: float(np.median([r[k] for r in got])) for k in got[0]}})
                print(f"numba at a process's start, {kernel} loop, cache {case}: {records[-1]['cpu_s']:.2f} s CPU "
                      f"(import {records[-1]['import_cpu_s']:.2f} s), median of {len(got)} processes")
            starts[kernel] = records[-1]["cpu_s"]
        print(f"\n{'target':<8} {'kernel':<9} {'numpy us/cycle':>15} {'numba us/cycle':>15} {'numba/numpy':>12} "
              f"{'ns/sample np':>13} {'nb':>7} {'same result':>12} {'break-even cycles':>18}")
        for target in targets:
            if target == "avx2" and simd != "AVX512F":
                print(f"avx2     (this machine's widest SIMD is {simd}: native is AVX2 or less already; skipped)")
                continue
            env = {"NUMBA_CACHE_DIR": os.path.join(cache, target), **(AVX2_ENV if target == "avx2" else {})}
            got = _child("kernels", env, args.repeats)
            for name in KERNELS:
                t = got["times"][name]
                numpy_us, numba_us = t["numpy_s"] / BATCH * 1e6, t["numba_s"] / BATCH * 1e6
                saving = numpy_us - numba_us
                rec = {"bench": "kernel", "target": target, "kernel": name, "batch": BATCH,
                       "samples_per_cycle": samples, "repeats": args.repeats,
                       "numpy_us_per_cycle": numpy_us, "numba_us_per_cycle": numba_us,
                       "numpy_ns_per_sample": numpy_us / samples * 1e3, "numba_ns_per_sample": numba_us / samples * 1e3,
                       "ratio": numba_us / numpy_us, "difference_eps": got["check"][name],
                       "break_even_cycles": starts[name] / (saving * 1e-6) if saving > 0 else None,
                       "numba": got["numba"], "svml": got["svml"], "numba_cpu": got["numba_cpu"],
                       "numpy_avx512": got["numpy_avx512"]}
                records.append(rec)
                same = "equal" if rec["difference_eps"] == 0 else f"{rec['difference_eps']:.3g} eps"
                even = f"{rec['break_even_cycles']:.3g}" if rec["break_even_cycles"] else "never"
                print(f"{target:<8} {name:<9} {numpy_us:15.1f} {numba_us:15.1f} {rec['ratio']:12.2f} "
                      f"{rec['numpy_ns_per_sample']:13.3f} {rec['numba_ns_per_sample']:7.3f} {same:>12} {even:>18}",
                      flush=True)
    runs = default_run_cycles()
    for name in KERNELS:
        print(f"{name}: {choice(records, name, runs)}")
    if args.json:
        bench_records.write(args.json, args, records, default_run_cycles=runs)
    return 0


def choice(records: list[dict[str, Any]], kernel: str, runs: int) -> str:
    """numpy or numba for `kernel` by the records (the rule of this module's docstring; `runs`: the cycles of a
    default run), and why: "keep numpy: ..." or "numba: ..."."""
    rows = [r for r in records if r["bench"] == "kernel" and r["kernel"] == kernel]
    if not rows:
        return "keep numpy: not measured"
    slower = [r["target"] for r in rows if r["ratio"] >= 1]
    if slower:
        return f"keep numpy: numba is not faster on {', '.join(slower)}"
    worst = max(r["break_even_cycles"] for r in rows)
    if worst > runs:
        return (f"keep numpy: numba is faster on {', '.join(r['target'] for r in rows)}, but its start cost is "
                f"repaid only after {worst:.3g} cycles (a default run: {runs})")
    return f"numba: faster on every target and repaid after {worst:.3g} cycles (a default run: {runs})"
