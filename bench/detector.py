"""`python3 dev.py bench detector`: numerical stress and speed of the CARAV detector and its Monte Carlo.

    stress    largest relative error of Q against an exact reference (samples taken as exact rationals, sums of
              squares exact, square roots in 40-digit decimal arithmetic) across scales 1e-30..1e30 (and 1e+-300
              for float64) and the four dtypes
    kernel    detect() in ns per sample per dtype, next to the memory bandwidth of np.copyto measured in the same run;
              adc_chirp_rms on int16 table1 codes in ns per code, beside numpy's floor for its exact sums and a copy
    sweep     table1, 5 RARMS x 1000 trials x 200 eta, full sample simulation (radar chain and paper model)
    energy    sufficient-statistic cycles per second (exact energy laws), table1

Medians over --repeat repetitions. Prints a table and writes JSON records with --json.
"""
from __future__ import annotations

import argparse
import time
from decimal import Decimal, getcontext
from fractions import Fraction

import numpy as np

from bench import records as bench_records
from carav_stream.console.options import count, output_file
from carav_stream.detect.detector import adc_chirp_rms, chirp_rms, detect
from carav_stream.montecarlo.engine import PaperSource, eta_grid, simulate_q, sweep
from carav_stream.montecarlo.paper_model import paper_scene
from carav_stream.montecarlo.radar_source import RadarSource
from carav_stream.radar.adc import adc_step
from carav_stream.radar.scene_loader import load_scene

__all__ = ["configure", "run", "exact_q"]

DTYPES = (np.float32, np.float64, np.complex64, np.complex128)


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--repeat", type=count(1), default=5, help="repetitions per timing (median reported)")
    parser.add_argument("--quick", action="store_true", help="smaller sizes (for a smoke test)")
    parser.add_argument("--skip-sweep", action="store_true", help="skip the table1 sweep timings")
    parser.add_argument("--json", type=output_file, default=None, metavar="FILE", help="write the records as JSON")


def _dec_sqrt(f: Fraction) -> Decimal:
    return (Decimal(f.numerator) / Decimal(f.denominator)).sqrt()


def exact_q(frames: np.ndarray, rho: np.ndarray, sigma_n: float) -> Decimal:
    """Q of one cycle computed exactly up to the 40-digit square roots (reference for the stress test)."""
    getcontext().prec = 40
    rms = []
    for chirp in frames:
        if np.iscomplexobj(chirp):
            vals = [Fraction(float(v.real)) ** 2 + Fraction(float(v.imag)) ** 2 for v in chirp]
        else:
            vals = [Fraction(float(v)) ** 2 for v in chirp]
        rms.append(_dec_sqrt(sum(vals, Fraction(0)) / len(chirp)))
    sig = Decimal(Fraction(float(sigma_n)).numerator) / Decimal(Fraction(float(sigma_n)).denominator)
    active = [r for r, a in zip(rms, rho) if a]
    rbar = sum(active, Decimal(0)) / Decimal(len(rho) // 2)
    d = [abs(r - rbar) / (rbar + sig) if a else r / sig for r, a in zip(rms, rho)]
    return max(d)


def _median_time(fn, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return float(np.median(times))


def bench_stress(quick: bool) -> list[dict]:
    rng = np.random.default_rng(0)
    out = []
    seeds = 2 if quick else 6
    for dtype in DTYPES:
        exps = list(range(-30, 31, 10 if quick else 5))
        if np.dtype(dtype) in (np.float64, np.complex128):
            exps += [-300, 300]
        worst, worst_exp = 0.0, None
        for e in exps:
            for _ in range(seeds):
                rho = np.zeros(8, bool)
                rho[rng.permutation(8)[:4]] = True
                x = rng.standard_normal((8, 16)) * rng.uniform(0.05, 5, (8, 1))
                if np.dtype(dtype).kind == "c":
                    x = x + 1j * rng.standard_normal((8, 16))
                x[rho] += 3 * np.cos(0.7 * np.arange(16))
                frames = (x * 10.0 ** e).astype(dtype)
                sigma = float(rng.uniform(0.5, 2)) * 10.0 ** e
                q = detect(frames, rho, sigma).q
                ref = exact_q(frames, rho, sigma)
                err = float(abs(Decimal(float(q)) - ref) / ref)
                if err > worst:
                    worst, worst_exp = err, e
        out.append({"bench": "stress", "dtype": np.dtype(dtype).name, "scales": f"1e{min(exps)}..1e{max(exps)}",
                    "max_rel_err_q": worst, "at_scale": f"1e{worst_exp}" if worst_exp is not None else "-",
                    "eps": float(np.finfo(np.dtype(dtype).type(0).real.dtype).eps)})
    return out


def bench_kernel(quick: bool, repeat: int) -> list[dict]:
    rng = np.random.default_rng(1)
    n_cycles = 40 if quick else 200
    out = []
    big = np.empty(32_000_000 if not quick else 4_000_000, dtype=np.float64)
    big[:] = 1.0
    dst = np.zeros_like(big)
    np.copyto(dst, big)                       # touch every page before timing
    t_copy = _median_time(lambda: np.copyto(dst, big), repeat)
    bw = 2 * big.nbytes / t_copy / 1e9
    out.append({"bench": "memory", "what": "np.copyto float64", "bytes": big.nbytes, "gb_per_s": bw})
    big = dst = None                          # free 512 MB before the kernels run
    rho = np.zeros((n_cycles, 64), bool)
    rho[:, ::2] = True
    for dtype in DTYPES:
        base = rng.standard_normal((n_cycles, 64, 1100), dtype=np.float32)
        if np.dtype(dtype).kind == "c":
            frames = (base[..., :550] + 1j * base[..., 550:]).astype(dtype)
        else:
            frames = base.astype(dtype)
        n = frames.size
        t_rms = _median_time(lambda: chirp_rms(frames), repeat)
        t_det = _median_time(lambda: detect(frames, rho, 1.0), repeat)
        out.append({"bench": "kernel", "dtype": np.dtype(dtype).name, "samples": n, "bytes": frames.nbytes,
                    "ns_per_sample_detect": t_det / n * 1e9, "ns_per_sample_rms": t_rms / n * 1e9,
                    "ns_per_cycle_detect": t_det / n_cycles * 1e9, "gb_per_s_read": frames.nbytes / t_det / 1e9,
                    "memory_gb_per_s": bw})
    return out


def bench_codes(repeat: int, n_cycles: int = 32) -> dict:
    """The int16 path the graph's detector takes (adc_chirp_rms on the ADC's codes) on a table1 frame of
    `n_cycles` cycles of receiver noise, in ns per code, beside numpy's floor for its exact sums (the kernel's own
    formulation alone: chunks of 256 chirps cast to float32 with astype, one np.matmul row dot product per chirp,
    exact here since every chirp's sum of noise codes stays below 2^24) and a plain read of the codes (np.copyto
    into another int16 array: read + write)."""
    scene = load_scene("table1")
    lsb = adc_step(scene)
    rng = np.random.default_rng(2)
    limit = 2 ** (scene.adc_bits - 1)
    codes = np.clip(np.rint(rng.standard_normal((n_cycles, scene.n_chirps, scene.n_samples)) * scene.sigma_n / lsb),
                    -limit, limit - 1).astype(np.int16)
    flat, copy = codes.reshape(-1, scene.n_samples), np.empty_like(codes)
    sumsq = np.empty(n_cycles * scene.n_chirps, np.float32)

    def exact_sums() -> None:
        for i in range(0, flat.shape[0], 256):
            x = flat[i: i + 256].astype(np.float32)
            np.matmul(x[:, None, :], x[:, :, None], out=sumsq[i: i + 256, None, None])

    n = codes.size
    many = max(repeat, 15)                    # a frame takes well under a millisecond: more repeats, same budget
    timed = {}
    for name, fn in (("kernel", lambda: adc_chirp_rms(codes, lsb, False)), ("bound", exact_sums),
                     ("read", lambda: np.copyto(copy, codes))):
        fn()                                  # warm: pages touched, allocator's threshold raised
        timed[name] = _median_time(fn, many) / n * 1e9
    return {"bench": "kernel_codes", "preset": "table1", "dtype": "int16", "shape": list(codes.shape), "codes": n,
            "ns_per_code": timed["kernel"], "bound_ns_per_code": timed["bound"],
            "x_bound": timed["kernel"] / timed["bound"],
            "bound": "astype float32 in chunks of 256 chirps + np.matmul row dot products",
            "read_ns_per_code": timed["read"], "x_read": timed["kernel"] / timed["read"],
            "read": "np.copyto int16 -> int16, read + write"}


def bench_sweep(quick: bool, repeat: int) -> list[dict]:
    out = []
    eta = eta_grid("0.5:2.49:0.01")            # 200 values
    rarms = [0.5, 1.0, 2.0, 3.0, 5.0]
    trials = 200 if quick else 1000
    reps = 1 if quick else max(1, min(repeat, 3))
    sources = [("paper model", PaperSource(paper_scene("table1")))]
    sources.insert(0, ("radar chain", RadarSource(load_scene("table1", {"snr_db": 0.0}))))
    for label, src in sources:
        t = _median_time(lambda: sweep(src, attacks=["random"], rarms=rarms, n_trials=trials, eta=eta, seed=1,
                                       method="samples"), reps)
        n_cycles = trials * (len(rarms) + 1)
        out.append({"bench": "sweep", "source": label, "rarms": len(rarms), "trials": trials, "eta": eta.size,
                    "cycles": n_cycles, "seconds": t, "cycles_per_s": n_cycles / t, "method": "samples"})
    return out


def bench_energy(quick: bool, repeat: int) -> list[dict]:
    out = []
    n = 100_000 if quick else 1_000_000
    src = PaperSource(paper_scene("table1"))
    simulate_q(src, "none", 0.0, 1000, np.random.SeedSequence(0), method="energy")      # build the tables
    for attack, rarms in (("none", 0.0), ("random", 1.0), ("smart", 1.0)):
        for workers in (1, 2):
            t = _median_time(lambda: simulate_q(src, attack, rarms, n, np.random.SeedSequence(1), method="energy",
                                                workers=workers), repeat)
            out.append({"bench": "energy", "scene": "table1 (paper model)", "attack": attack, "workers": workers,
                        "cycles": n, "seconds": t, "cycles_per_s": n / t})
    return out


def _print(records: list[dict]) -> None:
    for r in records:
        b = r["bench"]
        if b == "machine":
            print(f"machine {r['cpus']} CPUs, 1-min load average {r['loadavg_1min']:.1f} at start")
        elif b == "stress":
            print(f"stress  {r['dtype']:<11} scales {r['scales']:<14} max rel err of Q {r['max_rel_err_q']:.2e} "
                  f"(at {r['at_scale']}, eps {r['eps']:.1e})")
        elif b == "memory":
            print(f"memory  {r['what']}: {r['gb_per_s']:.2f} GB/s (read + write)")
        elif b == "kernel":
            print(f"kernel  {r['dtype']:<11} detect {r['ns_per_sample_detect']:.3f} ns/sample "
                  f"({r['ns_per_cycle_detect'] / 1e3:.1f} us/cycle of 64x1100, {r['gb_per_s_read']:.2f} GB/s read; "
                  f"chirp_rms alone {r['ns_per_sample_rms']:.3f} ns/sample)")
        elif b == "kernel_codes":
            print(f"kernel  int16 codes adc_chirp_rms {r['ns_per_code']:.3f} ns/code ({r['preset']}, "
                  f"{' x '.join(map(str, r['shape']))}); bound {r['bound_ns_per_code']:.3f} ns/code ({r['bound']}), "
                  f"x{r['x_bound']:.2f}; read {r['read_ns_per_code']:.3f} ns/code ({r['read']}), x{r['x_read']:.1f}")
        elif b == "sweep":
            print(f"sweep   table1 {r['source']:<12} {r['rarms']} RARMS x {r['trials']} trials x {r['eta']} eta, "
                  f"full samples: {r['seconds']:.2f} s ({r['cycles_per_s']:.0f} cycles/s)")
        elif b == "energy":
            print(f"energy  {r['scene']} {r['attack']:<7} workers {r['workers']}: {r['cycles_per_s']:.3g} cycles/s "
                  f"({r['cycles']} cycles in {r['seconds']:.2f} s)")


def run(args: argparse.Namespace) -> int:
    import os

    print(bench_records.header(), flush=True)
    records = [{"bench": "machine", "cpus": os.cpu_count(), "loadavg_1min": os.getloadavg()[0]}]
    records += bench_stress(args.quick)
    records += bench_kernel(args.quick, args.repeat)
    records.append(bench_codes(args.repeat))
    if not args.skip_sweep:
        records += bench_sweep(args.quick, args.repeat)
    records += bench_energy(args.quick, args.repeat)
    _print(records)
    if args.json:
        bench_records.write(args.json, args, records)
    return 0
