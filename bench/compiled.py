"""`python3 dev.py bench compiled`: the graph's hot kernels in numpy (the package's own functions) against one-pass
loops compiled with numba (bench/compiled_loops.py), on this machine's widest vector code and on AVX2 code, and
what numba would cost at the start of a graph whose zygote (runtime/zygote.py) imported it and compiled the loops
before forking the nodes. The rule (`choice`) weighs two things: the CPU the zygote pays, once per run, must be
repaid by the loops within a default run (the cycles of the graph `python3 dev.py demo` runs: default_run_cycles),
and the wall time it adds to the zygote's readiness, on every graph's path to its first frame, must not take a
graph's start past the start-up target (bench/startup.py); the package keeps numpy for a kernel unless both hold.

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

Start, a fresh node: a fresh process (numpy imported already, as in a node started as an interpreter, with
CARAV_ZYGOTE=0) imports numba and makes the first call of one kernel's loop (a node runs one); its CPU time with an
empty numba cache (compiles) and with a warm one (loads the machine code), medians of --starts processes each.
Break-even for such a node (the kernel records' break_even_cycles) = the warm cost / what the loop saves a cycle on
the slower target.

Start, the zygote: a process that does what the zygote does before it forks (zygote.preload, then the demo graph's
blocks as a run of it has the zygote import them, its one-thread check, gc.freeze), with the nodes' environment,
and with numba imported and every loop called once after its imports (cache cold and warm) or without numba; the
wall time from its interpreter's start to its line that it is ready, the CPU of each step, its threads; then it
forks a node that calls every loop once: each call's time and whether it compiled anything again. --starts
rounds, one zygote of each case a round, in turn; medians. Beside it, the start-up benchmark's yardsticks in the same
sitting (bench startup's timed runs): the demo graph's run with the zygote and one interpreter's imports, whose
ratio the target bounds.

The rule for the kernels numba is faster for on every target, together (they share numba's import): CPU = numba's
import and their loops' first calls in the zygote (warm cache: the cold one is paid once per machine and numba
version), paid once per run; repaid after CPU / what the loops save a cycle together (on the target where they save
least) cycles, against a default run's. Wall: the warm zygote's readiness less the one without numba, counted in
full against the graph's start (it overlaps the command's graph validation in part, so this is its upper bound):
(graph's start + that) / one interpreter's imports, against the target; an addition smaller than the spread of the
zygotes' readiness (some zygote without numba readier later than some with it) is not counted.
"""
from __future__ import annotations

import argparse
import functools
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
from bench.compiled_loops import KERNELS, adc_compiled, compiled_kernels, noise_compiled, rms_compiled
from carav_stream.console.options import count, output_file
from carav_stream.core.allocator import keep_freed_memory
from carav_stream.detect.detector import chirp_rms_codes
from carav_stream.radar.adc import adc_codes, adc_step
from carav_stream.radar.noise import standard_normal_rows
from carav_stream.radar.scene_loader import load_scene
from carav_stream.runtime.launcher import node_env
from carav_stream.runtime.loader import load_graph

ROOT = Path(__file__).resolve().parents[1]
BATCH = 32                    # cycles per frame (graphs/radar_chain.toml)
DEFAULT_GRAPH = ROOT / "graphs" / "demo.toml"     # what `python3 dev.py demo` runs
AVX2_ENV = {"NUMBA_CPU_NAME": "haswell", "NUMBA_CPU_FEATURES": "",
            "NPY_DISABLE_CPU_FEATURES": "X86_V4 AVX512_ICL AVX512_SPR"}


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--json", type=output_file, metavar="FILE", help="write the records as JSON to FILE")
    parser.add_argument("--repeats", type=count(1), default=15, help="alternated rounds per kernel (default 15)")
    parser.add_argument("--starts", type=count(1), default=3,
                        help="processes per start case: fresh nodes, zygotes, graph starts (default 3)")
    parser.add_argument("--targets", default="native,avx2", help="comma-separated: native, avx2 (default both)")


def default_run_cycles() -> int:
    """The cycles of a default run: those of the graph `python3 dev.py demo` runs."""
    return int(load_graph(DEFAULT_GRAPH).run["cycles"])


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


@functools.cache
def _demo_blocks() -> list[str]:
    """The block types of the demo graph: what its run's zygote imports (read once per benchmark)."""
    return sorted({node.type for node in load_graph(DEFAULT_GRAPH).nodes.values()})


def zygote_start(mode: str, cache: str) -> dict[str, Any]:
    """One zygote of `mode` (child_zygote) with numba's cache in `cache`: its lines, and the wall seconds from its
    start (the interpreter's) to its line that it is ready."""
    code = f"from bench import compiled_loops as c; c.child_zygote({mode!r}, {_demo_blocks()!r})"
    t0 = time.perf_counter()
    env = {**node_env(), "NUMBA_CACHE_DIR": cache}             # a zygote's: the nodes' environment
    with subprocess.Popen([sys.executable, "-c", code], cwd=ROOT, env=env,
                          stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) as proc:
        first = proc.stdout.readline()
        wall = time.perf_counter() - t0
        rest, err = proc.communicate()
    lines = [first, *rest.splitlines()]
    if proc.returncode or not first or (mode != "numpy" and len(lines) < 2):     # a numba zygote forks a node
        raise RuntimeError(f"bench compiled: the zygote ({mode}) failed (status {proc.returncode}, its lines "
                           f"{lines}):\n{err.strip()}")
    return {"ready": json.loads(lines[0]), "node": json.loads(lines[1]) if len(lines) > 1 else None,
            "ready_wall_s": wall}


def _child(what: str, env: dict[str, str], arg: Any) -> dict[str, Any]:
    module = "compiled_loops" if what == "start" else "compiled"
    code = f"import json; from bench import {module} as c; print(json.dumps(c.child_{what}({arg!r})))"
    proc = subprocess.run([sys.executable, "-c", code], cwd=ROOT, env={**os.environ, **env},
                          capture_output=True, text=True)
    if proc.returncode:
        raise RuntimeError(f"bench compiled: the {what} process failed:\n{proc.stderr.strip()}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def _median(got: list[dict[str, Any]], key: str) -> Any:
    """The median of `key` over `got`, per kernel when it is a mapping of them."""
    if isinstance(got[0][key], dict):
        return {k: float(np.median([g[key][k] for g in got])) for k in got[0][key]}
    return float(np.median([g[key] for g in got]))


def measure_node_starts(starts: int, cache: str) -> list[dict[str, Any]]:
    """numba at a fresh process's start (child_start), per kernel, cold and warm cache: records."""
    records = []
    for kernel in KERNELS:
        runs: dict[str, list[dict[str, float]]] = {"cold": [], "warm": []}
        for i in range(starts):         # cold: an empty cache each time; warm: the cache the cold one left
            env = {"NUMBA_CACHE_DIR": os.path.join(cache, f"{kernel}{i}")}
            runs["cold"].append(_child("start", env, kernel))
            runs["warm"].append(_child("start", env, kernel))
        for case, got in runs.items():
            records.append({"bench": "start", "kernel": kernel, "cache": case, "processes": len(got),
                            **{k: _median(got, k) for k in got[0]}})
            print(f"numba at a fresh process's start, {kernel} loop, cache {case}: {records[-1]['cpu_s']:.2f} s CPU "
                  f"(import {records[-1]['import_cpu_s']:.2f} s), median of {len(got)} processes")
    return records


def measure_zygote(starts: int, cache: str) -> list[dict[str, Any]]:
    """Zygotes without numba ("none"), and with it, cache cold and warm (child_zygote), in rounds that start one of
    each (in turn, the cold one before the warm one that reads its cache): a record per case, medians."""
    got: dict[str, list[dict[str, Any]]] = {"none": [], "cold": [], "warm": []}
    for i in range(starts):
        order = ["none", "cold", "warm"] if i % 2 == 0 else ["cold", "warm", "none"]
        for case in order:
            z = zygote_start("numpy" if case == "none" else "numba", os.path.join(cache, f"zygote{i}"))
            node = z["node"] or {}
            got[case].append({**z["ready"], "ready_wall_s": z["ready_wall_s"], "node_wall_s": node.get("wall_s"),
                              "node_cpu_s": node.get("cpu_s"), "recompiled": node.get("recompiled", []),
                              "forked": node.get("parent") == z["ready"]["pid"] != node.get("pid")})
    records = []
    for case, runs in got.items():
        rec = {"bench": "zygote", "cache": case, "processes": len(runs),
               "ready_wall_s": [r["ready_wall_s"] for r in runs], "ready_wall_median_s": _median(runs, "ready_wall_s"),
               "preload_cpu_s": _median(runs, "preload_cpu_s"), "threads": max(r["threads"] for r in runs)}
        if case != "none":
            rec.update({k: _median(runs, k) for k in ("import_cpu_s", "loop_cpu_s", "node_wall_s", "node_cpu_s")})
            rec.update(from_cache=sorted(set.intersection(*(set(r["from_cache"]) for r in runs))),
                       recompiled=sorted({k for r in runs for k in r["recompiled"]}),
                       forked=all(r["forked"] for r in runs))
        records.append(rec)
        numba_cpu = (f", numba {rec['import_cpu_s'] + sum(rec['loop_cpu_s'].values()):.2f} s (loops loaded from the "
                     f"cache: {', '.join(rec['from_cache']) or 'none'})" if case != "none" else "")
        node = (f"; a forked node's first calls {sum(rec['node_wall_s'].values()) * 1e3:.1f} ms, compiled again: "
                f"{', '.join(rec['recompiled']) or 'none'}" if case != "none" else "")
        print(f"zygote, numba {'not imported' if case == 'none' else 'cache ' + case}: ready after "
              f"{rec['ready_wall_median_s']:.2f} s; CPU: its imports {rec['preload_cpu_s']:.2f} s{numba_cpu}; "
              f"{rec['threads']} thread(s){node}")
    return records


def measure_graph_start(runs: int) -> dict[str, Any]:
    """bench startup's yardsticks in this sitting: the demo graph's run with the zygote and one interpreter's
    imports, alternated, medians (bench/startup.py, whose target the wall a zygote adds counts against)."""
    from bench import startup

    walls: dict[str, list[float]] = {"zygote": [], "import": []}
    with tempfile.TemporaryDirectory(prefix="cs", dir="/tmp") as tmp:    # ipc paths must stay short
        for _ in range(runs):
            for mode in walls:
                walls[mode].append(startup.timed_run(mode, 32, {**os.environ, "CARAV_RUN_DIR": tmp}, Path(tmp))[0])
    rec = {"bench": "graph_start", "graph": "graphs/demo.toml", "cycles": 32, "runs": runs, "imports": startup.IMPORTS,
           "graph_s": float(np.median(walls["zygote"])), "import_s": float(np.median(walls["import"])),
           "target_ratio": startup.TARGET_RATIO}
    print(f"a graph's start (bench startup): {rec['graph_s']:.2f} s, one interpreter's imports {rec['import_s']:.2f} s "
          f"({rec['graph_s'] / rec['import_s']:.2f} x; target <= {rec['target_ratio']:g} x)")
    return rec


def measure_kernels(target: str, repeats: int, cache: str, starts: dict[str, float]) -> list[dict[str, Any]]:
    """One target's kernel records (child_kernels in a process of its own); `starts`: a fresh node's warm cost."""
    scene = load_scene("table1")
    samples = scene.n_chirps * scene.n_samples
    env = {"NUMBA_CACHE_DIR": os.path.join(cache, target), **(AVX2_ENV if target == "avx2" else {})}
    got = _child("kernels", env, repeats)
    records = []
    for name in KERNELS:
        t = got["times"][name]
        numpy_us, numba_us = t["numpy_s"] / BATCH * 1e6, t["numba_s"] / BATCH * 1e6
        saving = numpy_us - numba_us
        rec = {"bench": "kernel", "target": target, "kernel": name, "batch": BATCH,
               "samples_per_cycle": samples, "repeats": repeats,
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
              f"{rec['numpy_ns_per_sample']:13.3f} {rec['numba_ns_per_sample']:7.3f} {same:>12} {even:>24}", flush=True)
    return records


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
    print(bench_records.header())
    simd = bench_records.machine()["simd"]
    with tempfile.TemporaryDirectory(prefix="carav-numba-") as cache:
        records = measure_node_starts(args.starts, cache)
        records += measure_zygote(args.starts, cache)
        records.append(measure_graph_start(args.starts))
        warm = {r["kernel"]: r["cpu_s"] for r in records if r["bench"] == "start" and r["cache"] == "warm"}
        print(f"\n{'target':<8} {'kernel':<9} {'numpy us/cycle':>15} {'numba us/cycle':>15} {'numba/numpy':>12} "
              f"{'ns/sample np':>13} {'nb':>7} {'same result':>12} {'break-even (fresh node)':>24}")
        for target in targets:
            if target == "avx2" and simd != "AVX512F":
                print(f"avx2     (this machine's widest SIMD is {simd}: native is AVX2 or less already; skipped)")
                continue
            records += measure_kernels(target, args.repeats, cache, warm)
    runs = default_run_cycles()
    for name in KERNELS:
        print(f"{name}: {choice(records, name, runs)}")
    if args.json:
        bench_records.write(args.json, args, records, default_run_cycles=runs)
    return 0


def choice(records: list[dict[str, Any]], kernel: str, runs: int) -> str:
    """numpy or numba for `kernel` by the records (the rule of this module's docstring; `runs`: the cycles of a
    default run), and why: "numba: ..." or "keep numpy...: ..." (in brackets, which of the two weights is against)."""
    rows = [r for r in records if r["bench"] == "kernel" and r["kernel"] == kernel]
    if not rows:
        return "keep numpy: not measured"
    slower = [r["target"] for r in rows if r["ratio"] >= 1]
    if slower:
        return f"keep numpy: numba is not faster on {', '.join(slower)}"
    ratios = [r["ratio"] for r in rows]
    span = f"{min(ratios):.2f}" + (f"-{max(ratios):.2f}" if f"{max(ratios):.2f}" != f"{min(ratios):.2f}" else "")
    faster = f"numba is faster on {', '.join(r['target'] for r in rows)} ({span} x)"
    zygote = {r["cache"]: r for r in records if r["bench"] == "zygote"}
    start = next((r for r in records if r["bench"] == "graph_start"), None)
    if start is None or not {"none", "warm"} <= set(zygote):
        return f"keep numpy: {faster}, but its start in the zygote is not measured"
    warm, none = zygote["warm"], zygote["none"]
    if warm["threads"] > 1:
        return f"keep numpy: {faster}, but numba leaves {warm['threads']} threads in the zygote (it forks no node)"
    if warm["recompiled"] or not warm["forked"]:
        return f"keep numpy: {faster}, but a node forked from the zygote compiles its loops again"
    by_target: dict[str, dict[str, dict]] = {}
    for r in records:
        if r["bench"] == "kernel":
            by_target.setdefault(r["target"], {})[r["kernel"]] = r
    together = [k for k in KERNELS if all(k in t and t[k]["ratio"] < 1 for t in by_target.values())]
    cpu = warm["import_cpu_s"] + sum(warm["loop_cpu_s"][k] for k in together)
    saving = min(sum(t[k]["numpy_us_per_cycle"] - t[k]["numba_us_per_cycle"] for k in together)
                 for t in by_target.values()) * 1e-6
    even = cpu / saving
    added = warm["ready_wall_median_s"] - none["ready_wall_median_s"]
    measurable = min(warm["ready_wall_s"]) > max(none["ready_wall_s"])   # every zygote with numba readier later
    before = start["graph_s"] / start["import_s"]
    after = (start["graph_s"] + max(added, 0.0)) / start["import_s"]
    cpu_ok, wall_ok = even <= runs, not measurable or after <= start["target_ratio"]
    cpu_text = (f"the zygote pays {cpu:.2f} s CPU once per run for {', '.join(together)}"
                f"{' together' if len(together) > 1 else ''}, repaid after "
                f"{even:.3g} cycles (a default run: {runs})")
    wall_text = (f"its readiness {added:+.2f} s{'' if measurable else ' (not measurable)'}, every graph's start "
                 f"{before:.2f} x -> {after:.2f} x one interpreter's imports (target <= {start['target_ratio']:g} x)")
    if cpu_ok and wall_ok:
        return f"numba: {faster}; {cpu_text}; {wall_text}"
    why = " and ".join(w for w, ok in (("CPU not repaid", cpu_ok), ("start past the target", wall_ok)) if not ok)
    return f"keep numpy ({why}): {faster}; {cpu_text}; {wall_text}"
