"""`python3 dev.py bench estimators`: run time against error of the range/velocity estimators.

For every estimator, preset (table1, awr1642: geometry from carav_stream.radar presets) and SNR after coherent
integration over the active chirps (-10..30 dB), it scores two sources of frames (bench/estimator_frames.py):
closed-form tones over the whole window (`tones`), and the radar chain's frames (`chain`, at the beat and the waveform
fidelity): the echo from its round trip on, the IF filter, the ADC. Per point it measures the range and velocity RMSE
against the truth, their ratio to the CRLB (carav_stream.estimate.crlb; for the chain, of the samples that hold the
echo) and the median run time per cycle (batches of --batch cycles, median over --repeat runs, estimators interleaved
so they share the machine's load). A baseline of tones with every chirp transmitting, at the same per-sample SNR,
measures what the random silencing costs. The radar's CFAR target lists (ca_cfar, os_cfar: CFAR on the range-Doppler
map at 1e-6 per cell, every cell refined by ml; the strongest listed target scored, a cycle listing none counted as
missing) are timed and scored beside the estimators, as the stage they add. Prints a table, the threshold SNR per
estimator, the Pareto front at --pareto-snr per preset and source (`dominates`: faster and not worse beyond the Monte
Carlo noise, or no slower and better beyond it) and the default estimator; --json writes one record per estimator,
preset, source, fidelity, SNR and rho mode; --plot draws error against time and RMSE/CRLB against SNR.
"""
from __future__ import annotations

import argparse
import time

import numpy as np
from threadpoolctl import threadpool_limits

from bench import estimator_frames
from bench import records as bench_records
from carav_stream.console.options import count, number, output_file
from carav_stream.estimate.estimators import DEFAULT_METHOD, METHODS, estimate
from carav_stream.estimate.geometry import Geometry
from carav_stream.experiments.reporting import load_preset
from carav_stream.firmware.target_list import target_list

__all__ = ["configure", "run", "measure", "measure_chain", "dominates", "pareto"]

PRESETS = ("table1", "awr1642")
SOURCES = ("tones", "chain")
FIDELITIES = ("beat", "waveform")
SNR_GRID_DB = tuple(range(-10, 31, 5))
TARGET_RATIO = 1.1
TARGET_TIME_FACTOR = 1.5   # refinement to the bound at FFT cost (at most 1.5 x fft_peak time)
LISTS = ("ca_cfar", "os_cfar")   # the radar's target list (CFAR on the map, each cell refined by ml) as a stage


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--presets", default=",".join(PRESETS), help="comma-separated presets")
    parser.add_argument("--estimators", default=",".join(METHODS + LISTS), help="comma-separated estimators, and the "
                        "CFAR target lists ca_cfar, os_cfar (strongest listed target, each refined by ml)")
    parser.add_argument("--sources", default=",".join(SOURCES), help="comma-separated sources of frames: tones "
                        "(closed form, whole window), chain (the radar chain's frames)")
    parser.add_argument("--fidelities", default=",".join(FIDELITIES), help="the chain's fidelities")
    parser.add_argument("--snr-db", default=",".join(str(s) for s in SNR_GRID_DB),
                        help="SNRs after coherent integration over the active chirps [dB]")
    parser.add_argument("--cycles", type=count(1), default=1000, help="Monte Carlo cycles per point (1000: an RMSE / "
                        "CRLB figure within about 2 %%, fine enough to judge the 1.1 target)")
    parser.add_argument("--batch", type=count(1), default=16, help="cycles per estimate() call")
    parser.add_argument("--repeat", type=count(1), default=5, help="timing repetitions (median reported)")
    parser.add_argument("--iq", choices=("preset", "complex", "real"), default="preset",
                        help="tones' sample type: the preset's, or force complex (I/Q) or real (I-only)")
    parser.add_argument("--pareto-snr", type=number(), default=20.0, help="SNR of the Pareto table [dB]")
    parser.add_argument("--seed", type=count(0), default=1, help="seed of the synthetic data (simulation only)")
    parser.add_argument("--quick", action="store_true", help="40 cycles, 2 repeats, 3 SNRs (smoke test)")
    parser.add_argument("--json", type=output_file, default=None, metavar="FILE", help="write the records as JSON")
    parser.add_argument("--plot", type=output_file, default=None, metavar="FILE.png", help="draw error against time")


def _estimate(x, rho, geometry, method, sigma_n):
    """(range, velocity) (C, 1): an estimator's first target, or a CFAR list's strongest (NaN: none listed)."""
    if method in LISTS:
        tl = target_list(x, rho, geometry, sigma_n, detection=method)
        return tl.range_m[:, :1], tl.velocity_mps[:, :1]
    e = estimate(x, rho, geometry, method=method)
    return e.range_m, e.velocity_mps


def _run_batches(x, rho, geometry, method, batch, sigma_n):
    outs = [_estimate(x[i:i + batch], rho[i:i + batch], geometry, method, sigma_n) for i in range(0, len(x), batch)]
    return np.concatenate([o[0] for o in outs]), np.concatenate([o[1] for o in outs])


def _score(frames: estimator_frames.Frames, methods, *, batch: int, repeat: int, **labels) -> list[dict]:
    """One record per method on `frames`: RMSEs against the truth and the bound, median time per cycle."""
    g, x, rho, sigma_n = frames.geometry, frames.x, frames.rho, frames.sigma_n
    times = {m: [] for m in methods}
    xb, rb = x[:batch], rho[:batch]
    for m in methods:  # warm-up (imports, FFT plans)
        _estimate(xb, rb, g, m, sigma_n)
    for _ in range(repeat):
        for m in methods:
            t0 = time.perf_counter()
            _estimate(xb, rb, g, m, sigma_n)
            times[m].append((time.perf_counter() - t0) / len(xb))
    r_crlb = float(np.sqrt(np.mean(frames.range_bound_m ** 2)))
    v_crlb = float(np.sqrt(np.mean(frames.velocity_bound_mps ** 2)))
    vmax = g.max_velocity_mps
    records = []
    for m in methods:
        r_est, v_est = _run_batches(x, rho, g, m, batch, sigma_n)
        r_rmse = float(np.sqrt(np.nanmean((r_est - frames.range_m) ** 2)))
        v_rmse = float(np.sqrt(np.nanmean(((v_est - frames.velocity_mps + vmax) % (2 * vmax) - vmax) ** 2)))
        records.append({
            "estimator": m, **labels, "snr_sample_db": float(frames.snr_sample_db), "iq": g.iq,
            "n_cycles": int(len(x)), "n_active": int(rho[0].sum()), "time_per_cycle_s": float(np.median(times[m])),
            "time_ratio_to_fft_peak": float(np.median(np.array(times[m]) / np.array(times["fft_peak"])))
            if "fft_peak" in times else None,
            "range_rmse_m": r_rmse, "range_crlb_m": r_crlb, "range_ratio": r_rmse / r_crlb,
            "velocity_rmse_mps": v_rmse, "velocity_crlb_mps": v_crlb, "velocity_ratio": v_rmse / v_crlb,
            "n_missing": int(np.isnan(r_est).sum()),
        })
    return records


def measure(preset: str, geometry: Geometry, n_chirps: int, range_m: float, rate_mps: float, snr_db: float,
            methods, *, n_cycles: int, batch: int, repeat: int, rng: np.random.Generator,
            all_chirps: bool = False) -> list[dict]:
    """Records of closed-form tones for one preset and SNR (after integration over n_chirps / 2 active chirps)."""
    frames = estimator_frames.tones(geometry, n_chirps, range_m, rate_mps, snr_db, n_cycles=n_cycles, rng=rng,
                                    all_chirps=all_chirps)
    return _score(frames, methods, batch=batch, repeat=repeat, preset=preset, source="tones", fidelity=None,
                  snr_db=float(snr_db), rho="all" if all_chirps else "random")


def measure_chain(preset: str, fidelity: str, snr_db: float, methods, *, n_cycles: int, batch: int, repeat: int,
                  rng: np.random.Generator) -> list[dict]:
    """Records of the radar chain's frames for one preset, fidelity and SNR (after integration)."""
    frames = estimator_frames.chain(preset, fidelity, snr_db, n_cycles=n_cycles, rng=rng)
    return _score(frames, methods, batch=batch, repeat=repeat, preset=preset, source="chain", fidelity=fidelity,
                  snr_db=float(snr_db), rho="random")


def where(r: dict) -> str:
    """A record's frames in words: "tones", or "chain, beat" / "chain, waveform"."""
    return r.get("source", "tones") + (f", {r['fidelity']}" if r.get("fidelity") else "")


def _rows(records: list[dict], preset: str, source: str | None = None, fidelity: str | None = None) -> list[dict]:
    """The records of a preset with random silencing, of one source and fidelity (None: every source)."""
    return [r for r in records if r["preset"] == preset and r["rho"] == "random"
            and (source is None or (r.get("source", "tones"), r.get("fidelity")) == (source, fidelity))]


def threshold_snr(records: list[dict], estimator: str, preset: str, limit: float = 2.0, source: str = "tones",
                  fidelity: str | None = None):
    """Lowest SNR from which the range RMSE stays within limit x CRLB at every higher SNR (None: never)."""
    rows = sorted((r for r in _rows(records, preset, source, fidelity) if r["estimator"] == estimator),
                  key=lambda r: r["snr_db"])
    best = None
    for r in reversed(rows):
        if r["range_ratio"] > limit:
            break
        best = r["snr_db"]
    return best


def dominates(o: dict, r: dict) -> bool:
    """Whether record o dominates record r (same frames): o misses no more cycles, and it is faster with a range
    RMSE not above r's beyond the Monte Carlo noise, or no slower with an RMSE below r's beyond it. The noise: two
    standard deviations of the difference of the two RMSEs, each 1 / sqrt(2 n) of itself over n cycles; an
    estimator that merely ties another's error within it (a CFAR list refined by ml against ml) is then judged by its
    time alone."""
    if o is r or o["n_missing"] > r["n_missing"]:
        return False
    tol = 2.0 * np.sqrt(0.5 / o["n_cycles"] + 0.5 / r["n_cycles"])
    eo, er = (x if np.isfinite(x) else np.inf for x in (o["range_rmse_m"], r["range_rmse_m"]))
    to, tr = o["time_per_cycle_s"], r["time_per_cycle_s"]
    return bool((to < tr and eo <= er * (1.0 + tol)) or (to <= tr and eo < er * (1.0 - tol)))


def pareto(records: list[dict], preset: str, snr_db: float, source: str = "tones",
           fidelity: str | None = None) -> list[dict]:
    """The records of one preset, source, fidelity and SNR, time ascending, each with `pareto`: no other
    dominates it."""
    rows = [r for r in _rows(records, preset, source, fidelity) if r["snr_db"] == snr_db]
    front = [dict(r, pareto=not any(dominates(o, r) for o in rows)) for r in rows]
    return sorted(front, key=lambda r: r["time_per_cycle_s"])


def scores(records: list[dict], presets) -> dict[str, tuple[float, float]]:
    """Per estimator: (worst RMSE/CRLB in range and velocity from 10 to 30 dB over `presets` and every source in
    the records, worst over presets and sources of the median time ratio to fft_peak)."""
    ok = {}
    groups = sorted({(r.get("source", "tones"), r.get("fidelity") or "") for r in records})
    for m in {r["estimator"] for r in records}:
        worst_ratio, worst_time = 0.0, 0.0
        for p in presets:
            for source, fidelity in groups:
                pick = _rows(records, p, source, fidelity or None)
                rows = [r for r in pick if r["estimator"] == m and 10 <= r["snr_db"] <= 30]
                base = [r for r in pick if r["estimator"] == "fft_peak" and 10 <= r["snr_db"] <= 30]
                if not base:
                    continue
                if not rows:
                    worst_ratio = np.inf
                    continue
                worst_ratio = max(worst_ratio, max(max(r["range_ratio"], r["velocity_ratio"]) for r in rows))
                # paired ratios (the two estimators timed back to back share the machine's load), median over SNRs
                worst_time = max(worst_time, float(np.median([r["time_ratio_to_fft_peak"] for r in rows])))
        ok[m] = (worst_ratio, worst_time)
    return ok


def choose_default(records: list[dict], presets) -> tuple[str | None, str]:
    """Fastest estimator holding TARGET_RATIO x CRLB (range and velocity) from 10 to 30 dB on every preset and source
    at no more than TARGET_TIME_FACTOR x the fft_peak time; returns (name, reason)."""
    ok = {m: v for m, v in scores(records, presets).items() if m in METHODS}   # the CFAR lists are a stage
    good = [m for m, (ratio, tf) in ok.items() if ratio <= TARGET_RATIO and tf <= TARGET_TIME_FACTOR]
    if good:
        best = min(good, key=lambda m: ok[m][1])
        return best, (f"{best}: worst RMSE/CRLB {ok[best][0]:.3f} (range and velocity, 10..30 dB, all presets and "
                      f"sources), {ok[best][1]:.2f} x the fft_peak time")
    if not ok:
        return None, "no records"
    best = min(ok, key=lambda m: (ok[m][0], ok[m][1]))
    return None, (f"no estimator met {TARGET_RATIO} x CRLB at <= {TARGET_TIME_FACTOR} x fft_peak time; closest: "
                  f"{best} (worst ratio {ok[best][0]:.3f}, {ok[best][1]:.2f} x fft_peak time)")


def _groups(records: list[dict]) -> list[tuple[str, str | None]]:
    """(source, fidelity) of the records, tones first."""
    found = {(r.get("source", "tones"), r.get("fidelity")) for r in records}
    return sorted(found, key=lambda g: (SOURCES.index(g[0]), g[1] or ""))


def _plot(records, presets, pareto_snr, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import NullFormatter
    groups = _groups(records)
    fig, axes = plt.subplots(2, len(presets), figsize=(6 * len(presets), 9), squeeze=False)
    methods = sorted({r["estimator"] for r in records})
    marks = dict(zip(groups, "os^v"))
    for j, p in enumerate(presets):
        ax = axes[0, j]
        for i, m in enumerate(methods):
            for g in groups:
                rows = [r for r in _rows(records, p, *g) if r["estimator"] == m and r["snr_db"] == pareto_snr]
                if rows:
                    ax.loglog([rows[0]["time_per_cycle_s"] * 1e3], [rows[0]["range_ratio"]], marks[g], color=f"C{i}",
                              label=f"{m} ({where(rows[0])})")
        for axis in (ax.xaxis, ax.yaxis):          # a narrow log span: minor labels would overlap the major ones
            axis.set_minor_formatter(NullFormatter())
        ax.axhline(1.0, color="k", ls="--", lw=0.8, label="CRLB")
        ax.set(xlabel="time per cycle [ms]", ylabel="range RMSE / CRLB (no unit)",
               title=f"{p}: error against time, {pareto_snr:g} dB after integration")
        ax.legend(fontsize=6, ncol=2)
        ax = axes[1, j]
        for i, m in enumerate(methods):
            for g in groups:
                rows = sorted((r for r in _rows(records, p, *g) if r["estimator"] == m), key=lambda r: r["snr_db"])
                if rows:
                    ax.semilogy([r["snr_db"] for r in rows], [r["range_ratio"] for r in rows], marks[g] + "-",
                                color=f"C{i}", ms=3, lw=0.8)
        ax.axhline(TARGET_RATIO, color="k", ls="--", lw=0.8, label=f"target {TARGET_RATIO:g} x CRLB")
        ax.yaxis.set_minor_formatter(NullFormatter())
        ax.set(xlabel="SNR after coherent integration [dB]", ylabel="range RMSE / CRLB (no unit)",
               title=f"{p}: range RMSE over the Cramer-Rao bound (markers: " +
                     ", ".join(f"{marks[g]} {g[0]}{', ' + g[1] if g[1] else ''}" for g in groups) + ")")
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _print(r: dict) -> None:
    xp = r["time_ratio_to_fft_peak"]
    xp = float("nan") if xp is None else xp
    print(f"{r['preset']:8s} {where(r):16s} {r['estimator']:12s} {r['rho']:6s} {r['snr_db']:6.1f} "
          f"{r['time_per_cycle_s'] * 1e3:9.3f} {xp:6.2f} {r['range_rmse_m']:12.3e} {r['range_ratio']:7.2f} "
          f"{r['velocity_rmse_mps']:12.3e} {r['velocity_ratio']:7.2f}", flush=True)


def _measure_all(args, presets, methods, snrs, n_cycles, repeat, rng) -> list[dict]:
    sources = [s.strip() for s in args.sources.split(",") if s.strip()]
    fidelities = [f.strip() for f in args.fidelities.split(",") if f.strip()]
    bad = [s for s in sources if s not in SOURCES] + [f for f in fidelities if f not in FIDELITIES]
    if bad:
        raise SystemExit(f"bench estimators: unknown source(s) or fidelity(ies) {bad}, expected some of "
                         f"{SOURCES} and {FIDELITIES}")
    records: list[dict] = []
    for p in presets:
        geometry, n_chirps, r0, rate = load_preset(p)
        if args.iq != "preset":
            import dataclasses
            geometry = dataclasses.replace(geometry, iq=args.iq == "complex")
        for snr in snrs:
            recs = []
            if "tones" in sources:
                recs += measure(p, geometry, n_chirps, r0, rate, snr, methods, n_cycles=n_cycles, batch=args.batch,
                                repeat=repeat, rng=rng)
                recs += measure(p, geometry, n_chirps, r0, rate, snr, ["fft_peak", DEFAULT_METHOD],
                                n_cycles=n_cycles, batch=args.batch, repeat=repeat, rng=rng, all_chirps=True)
            for fidelity in fidelities if "chain" in sources else ():
                recs += measure_chain(p, fidelity, snr, methods, n_cycles=n_cycles, batch=args.batch, repeat=repeat,
                                      rng=rng)
            for r in recs:
                _print(r)
            records += recs
    return records


def run(args: argparse.Namespace) -> int:
    presets = [p.strip() for p in args.presets.split(",") if p.strip()]
    methods = [m.strip() for m in args.estimators.split(",") if m.strip()]
    bad = [m for m in methods if m not in METHODS + LISTS]
    if bad:
        raise SystemExit(f"bench estimators: unknown estimator(s) {bad}, expected some of {METHODS + LISTS}")
    snrs = [float(s) for s in args.snr_db.split(",")]
    n_cycles, repeat = args.cycles, args.repeat
    if args.quick:
        n_cycles, repeat, snrs = 40, 2, [0.0, 20.0, 30.0]
    if "fft_peak" not in methods:
        methods = ["fft_peak"] + methods
    rng = np.random.default_rng(args.seed)
    # Timed as a graph's node runs them: one BLAS thread (supervisor.NODE_ENV). A multithreaded BLAS call (music's
    # eigendecompositions) otherwise leaves its worker threads spinning into whatever is timed next.
    blas = threadpool_limits(limits=1, user_api="blas")
    print(f"{'preset':8s} {'frames':16s} {'estimator':12s} {'rho':6s} {'SNR dB':>6s} {'ms/cycle':>9s} {'xpeak':>6s} "
          f"{'range RMSE m':>12s} {'/CRLB':>7s} {'vel RMSE m/s':>12s} {'/CRLB':>7s}")
    records = _measure_all(args, presets, methods, snrs, n_cycles, repeat, rng)
    blas.restore_original_limits()
    print("\nthreshold SNR (range RMSE within 2 x CRLB from there up), dB:")
    groups = _groups(records)
    for p in presets:
        for g in groups:
            print(f"  {p}, {g[0]}{', ' + g[1] if g[1] else ''}: "
                  + ", ".join(f"{m} {threshold_snr(records, m, p, source=g[0], fidelity=g[1])}" for m in methods))
    psnr = args.pareto_snr if args.pareto_snr in snrs else snrs[-1]
    for p in presets:
        for g in groups:
            print(f"\nPareto at {psnr:g} dB, {p}, {g[0]}{', ' + g[1] if g[1] else ''} (time ascending; * = not "
                  "dominated):")
            for r in pareto(records, p, psnr, *g):
                print(f"  {'*' if r['pareto'] else ' '} {r['estimator']:12s} {r['time_per_cycle_s'] * 1e3:8.3f} ms "
                      f"({r['time_ratio_to_fft_peak']:.2f} x fft_peak)  "
                      f"range {r['range_rmse_m']:.3e} m ({r['range_ratio']:.2f} x CRLB)")
    name, reason = choose_default(records, presets)
    print(f"\ndefault estimator: {name} -- {reason}")
    if args.json:
        bench_records.write(args.json, args, records, default=name, reason=reason, pareto_snr=psnr)
    if args.plot:
        _plot(records, presets, psnr, args.plot)
    return 0
