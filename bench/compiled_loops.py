"""numba's loops of `python3 dev.py bench compiled` (bench/compiled.py), one per hot kernel, each giving the
package's result (its wrapper takes the kernel's arguments), and what a process that runs them measures of numba's
start: a fresh node's (child_start) and a zygote's, with what a node forked from it pays (child_zygote). Numba is
imported by compiled_kernels, on first use."""
from __future__ import annotations

import gc
import json
import os
import sys
import time
from typing import Any

import numpy as np

from carav_stream.radar.adc import adc_step
from carav_stream.radar.noise import words as raw_words
from carav_stream.radar.scene_loader import load_scene
from carav_stream.runtime import zygote

KERNELS = ("adc", "detector", "noise")
LOOPS = {"adc": "adc", "detector": "sumsq", "noise": "box_muller"}    # each kernel's loop in compiled_kernels


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


def first_call(kernels: dict, kernel: str, scene) -> None:
    """One call of `kernel`'s loop on a small input of the types a node's frames have (what compiles it, or loads
    it from numba's cache, in a process that has not called it yet); `scene`: the node's (table1)."""
    if kernel == "adc":
        rx = np.zeros((1, 2, 8), np.float32)
        adc_compiled(kernels, scene, rx, rx, np.empty((1, 2, 8), np.int16))
    elif kernel == "detector":
        rms_compiled(kernels, np.zeros((1, 2, 8), np.int16), 1.0, False)
    else:
        noise_compiled(kernels, np.random.default_rng(0), 1, 8, 1.0, np.empty((1, 8), np.float32))


def child_start(kernel: str) -> dict[str, float]:
    """A fresh process's cost of numba for one kernel (a node runs one): import, then its loop's first call
    (compiled, or loaded from numba's cache)."""
    scene = load_scene("table1")
    c0, w0 = time.process_time(), time.perf_counter()
    kernels = compiled_kernels()
    c1 = time.process_time()
    first_call(kernels, kernel, scene)
    return {"cpu_s": time.process_time() - c0, "import_cpu_s": c1 - c0, "wall_s": time.perf_counter() - w0}


def child_zygote(mode: str, blocks: list[str]) -> None:
    """A zygote as runtime/zygote.py makes one for a graph of these `blocks` (its imports: zygote.preload, then the
    graph's blocks, zygote.import_blocks; its check that one thread is left, gc.freeze), with numba imported and
    every loop called once after its imports unless `mode` is "numpy"; prints a JSON line when ready (what a forked
    node would find: CPU seconds of each step, threads), then forks a node, which calls every loop once, and prints
    a line of what that node measured: each call's wall and CPU seconds, and the loops compiled again in it
    (overloads added to a dispatcher)."""
    scene = load_scene("table1")
    c0 = time.process_time()
    problems = zygote.preload() + zygote.import_blocks(blocks)
    ready: dict[str, Any] = {"pid": os.getpid(), "preload_cpu_s": time.process_time() - c0, "problems": problems}
    kernels: dict[str, Any] = {}
    if mode != "numpy":
        c1 = time.process_time()
        kernels = compiled_kernels()
        ready["import_cpu_s"] = time.process_time() - c1
        ready["loop_cpu_s"] = {k: _timed(first_call, kernels, k, scene)[1] for k in KERNELS}
        ready["from_cache"] = [k for k in KERNELS if sum(kernels[LOOPS[k]].stats.cache_hits.values())]
    ready["threads"] = zygote.threads()
    ready["numba_imported"] = "numba" in sys.modules
    gc.freeze()
    print(json.dumps(ready), flush=True)
    if not kernels:
        return
    read, write = os.pipe()
    pid = os.fork()
    if pid == 0:                                         # the node: never returns
        status = 1
        try:
            before = {k: len(kernels[LOOPS[k]].overloads) for k in KERNELS}
            calls = {k: _timed(first_call, kernels, k, scene) for k in KERNELS}
            node = {"pid": os.getpid(), "parent": os.getppid(), "wall_s": {k: c[0] for k, c in calls.items()},
                    "cpu_s": {k: c[1] for k, c in calls.items()},
                    "recompiled": [k for k in KERNELS if len(kernels[LOOPS[k]].overloads) != before[k]]}
            os.write(write, json.dumps(node).encode())
            status = 0
        finally:
            os._exit(status)
    os.close(write)
    with os.fdopen(read, "rb") as fh:
        node = json.loads(fh.read() or b"null")
    if os.waitpid(pid, 0)[1] != 0 or node is None:
        raise RuntimeError("bench compiled: the node forked from the zygote failed")
    print(json.dumps(node), flush=True)


def _timed(fn, *args) -> tuple[float, float]:
    """(wall, CPU) seconds of fn(*args)."""
    c0, w0 = time.process_time(), time.perf_counter()
    fn(*args)
    return time.perf_counter() - w0, time.process_time() - c0
