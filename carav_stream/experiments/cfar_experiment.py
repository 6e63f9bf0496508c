"""`carav experiment cfar`: the radar's target detection measured against its design (carav_stream/firmware/cfar.py).

1. False alarms. Noise-only cycles of a preset's shape (its chirps, samples, I-only or I/Q; white Gaussian noise,
   balanced random activation, half the chirps silent): the share of map cells above the CA- and OS-CFAR thresholds
   against the design rate per cell, and the targets listed per cycle (local maxima, sidelobes removed) against
   the design rate times the cells per cycle.
2. Detection. A Swerling 1 target (complex Gaussian amplitude per cycle, steady over the cycle's chirps) on the
   centre of a range and a Doppler bin, at a given SNR after integration: the share of cycles whose CA-CFAR
   threshold it exceeds in its own cell, beside the textbook curve for CA-CFAR on exponential cells,
   Pd = (1 + alpha / (n (1 + SNR)))^-n, with SNR the cell's mean signal-to-noise ratio on the Hann-windowed map.
3. The list refined (carav_stream/firmware/target_list.py, pfa 1e-6 per cell, ml). table1 and awr1642 beat signals, one
   target at 10, 20 and 30 dB after integration over the active chirps, its echo from its round trip on and its
   range walking over the cycle (estimate/tones.py; CRLB of the samples holding the echo from estimate/crlb.py, the
   truth the range at the active chirps' mean time): range and velocity RMSE over the bound, and the targets listed
   per cycle. Then two targets 12 range bins apart, one
   20 dB louder (the weak one at 20 dB): the share of cycles in which the weak one is listed, CA against OS.
   Then the resolution limit: two equal targets (20 dB each) 0.5 to 3 range bins apart at the same velocity: the
   share of cycles listing both, and listing the pair as one target.
4. Range migration. The awr1642 car (closing at 83 m/s: 3.6 range cells within a cycle, Doppler aliased) through
   the simulator's signal chain, and the same car 30, 40 and 45 dB weaker (RCS): the OS-CFAR list with and without
   the range-walk compensation (max_speed_mps 100, estimate/migration.py): probability of detection, false targets
   per cycle, the SNR after integration CFAR measured in the listed car's cell (median), its range and velocity
   RMSE against the truth (velocity unaliased), and the share of cycles whose velocity alias is the true one.
"""
from __future__ import annotations

import argparse

import numpy as np

from carav_stream.console.options import count, number
from carav_stream.detect.rdmap import rd_power
from carav_stream.estimate.crlb import fmcw_crlb
from carav_stream.estimate.geometry import Geometry
from carav_stream.estimate.tones import centroid_ranges, synth_beat
from carav_stream.experiments.reporting import load_preset
from carav_stream.firmware import cfar
from carav_stream.firmware.target_list import associate, gates, target_list
from carav_stream.radar.activation import balanced_rows
from carav_stream.radar.scene_loader import load_scene
from carav_stream.radar.streams import scene_of
from carav_stream.radar.synth import simulate_cycles

__all__ = ["configure", "run"]


def configure(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--preset", default="table1", help="the scene whose map shape is used (default table1)")
    parser.add_argument("--trials", type=count(1), default=400, help="cycles per measurement")
    parser.add_argument("--pfa", type=number(0.0, strict=True), default=1e-4, help="design false-alarm rate per cell")
    parser.add_argument("--seed", type=count(0), default=5, help="seed")


def _frames(rng, c, m, n, iq):
    x = rng.standard_normal((c, m, n))
    return (x + 1j * rng.standard_normal((c, m, n))) / np.sqrt(2) if iq else x


def run(args: argparse.Namespace) -> int:
    import scipy.signal


    scene = load_scene(args.preset)
    m, n, iq = scene.n_chirps, scene.n_samples, scene.iq
    rng = np.random.default_rng(args.seed)
    c = args.trials
    rho = balanced_rows(rng, c, m)
    p = rd_power(_frames(rng, c, m, n, iq), rho, 1.0)
    cells = p.shape[1] * p.shape[2]
    print(f"{scene.name} map: {m} Doppler x {p.shape[2]} range cells, half the chirps silent, {c} noise-only "
          f"cycles, seed {args.seed}; design {args.pfa:g} per cell, training 8 cells each side every third bin")
    print(f"{'CFAR':<6}{'cells above threshold':>24}{'design':>10}{'targets listed/cycle':>22}{'design':>10}")
    for kind in ("ca", "os"):
        hit = np.mean(p > cfar.cfar_threshold(p, pfa=args.pfa, kind=kind))
        listed = cfar.detect_targets(p, rho, pfa=args.pfa, kind=kind, max_targets=64).n_found.mean()
        print(f"{kind:<6}{hit:>24.3g}{args.pfa:>10.3g}{listed:>22.3g}{args.pfa * cells:>10.3g}")
    # detection of a Swerling 1 target centred on a cell, against the textbook curve
    w = scipy.signal.windows.hann(n, sym=False)
    gain = (w.sum() ** 2 / (w @ w))                                    # coherent gain over noise gain, per chirp
    alpha, n_train = cfar.ca_alpha(args.pfa, 16), 16
    k_bin, l_bin = n // 5, m // 8
    t, mm = np.arange(n), np.arange(m)[:, None]
    print(f"Swerling 1 target on range bin {k_bin}, Doppler bin {l_bin}; CA-CFAR, {c} cycles per SNR")
    print(f"{'SNR after integration':>22}{'Pd measured':>13}{'Pd textbook':>13}")
    for snr_db in (5.0, 10.0, 15.0, 20.0, 25.0):
        snr = 10 ** (snr_db / 10)
        # mean per-sample power giving that cell SNR: a real tone puts half its power in the positive-frequency bin
        a2 = snr / (m / 2 * gain * (1.0 if iq else 0.5))
        amp = np.sqrt(a2 / 2) * (rng.standard_normal(c) + 1j * rng.standard_normal(c))   # Rayleigh, per cycle
        tone = np.exp(2j * np.pi * (k_bin * t / n + l_bin * mm / m))
        x = _frames(rng, c, m, n, iq) + (amp[:, None, None] * tone if iq else
                                           np.real(np.sqrt(2) * amp[:, None, None] * tone))
        rho = balanced_rows(rng, c, m)
        q = rd_power(x, rho, 1.0)
        col = k_bin if iq else k_bin - 1                                # I-only maps drop DC
        thr = cfar.cfar_threshold(q, pfa=args.pfa, kind="ca")
        pd = np.mean(q[:, l_bin, col] > thr[:, l_bin, col])
        print(f"{snr_db:>19.0f} dB{pd:>13.3f}{(1 + alpha / (n_train * (1 + snr))) ** -n_train:>13.3f}")
    _refined_list(rng, max(40, c // 4))
    _migration(args.seed, min(c, 64))
    return 0


def _refined_list(rng, c: int) -> None:
    print(f"The list refined (ml), pfa 1e-6 per cell, {c} cycles per point: RMSE over the CRLB")
    print(f"{'preset':<9}{'SNR after integration':>22}{'range':>8}{'velocity':>10}{'listed/cycle':>14}")
    for preset in ("table1", "awr1642"):
        g, m, r0, v0 = load_preset(preset)
        vmax = g.max_velocity_mps
        for snr_db in (10.0, 20.0, 30.0):
            rho = balanced_rows(rng, c, m)
            truth_r = np.full((c, 1), min(r0, 0.8 * g.max_range_m)) + rng.uniform(-0.5, 0.5, (c, 1)) * \
                g.range_resolution_m
            truth_v = np.full((c, 1), (v0 + vmax) % (2 * vmax) - vmax)
            snr_s = snr_db - 10 * np.log10(m // 2)
            # echoes from their round trips on, their ranges walking: the estimators' model of a radar's echo
            x = synth_beat(g, rho, truth_r, truth_v, snr_sample_db=snr_s, rng=rng, migrate=True, gate=True)
            sigma = 10 ** (-snr_s / 20) / (1.0 if g.iq else np.sqrt(2.0))
            tl = target_list(x, rho, g, sigma)
            bound = fmcw_crlb(g, snr_s, rho, range_m=truth_r[:, 0])
            err_r = tl.range_m[:, 0] - centroid_ranges(g, rho, truth_r, truth_v)[:, 0]
            err_v = (tl.velocity_mps[:, 0] - truth_v[:, 0] + vmax) % (2 * vmax) - vmax
            print(f"{preset:<9}{snr_db:>19.0f} dB"
                  f"{np.sqrt(np.nanmean(err_r ** 2) / np.mean(bound['range_m'] ** 2)):>8.2f}"
                  f"{np.sqrt(np.nanmean(err_v ** 2) / np.mean(bound['velocity_mps'] ** 2)):>10.2f}"
                  f"{tl.n_found.mean():>14.3f}")
    g, m, r0, _ = load_preset("table1")
    rho = balanced_rows(rng, c, m)
    ranges = np.tile([0.3 * g.max_range_m, 0.3 * g.max_range_m + 12 * g.range_resolution_m], (c, 1))
    speeds = np.tile([0.2 * g.max_velocity_mps, -0.4 * g.max_velocity_mps], (c, 1))
    snr_s = 20.0 - 10 * np.log10(m // 2)
    x = synth_beat(g, rho, ranges, speeds, amplitudes=np.array([1.0, 10.0]), snr_sample_db=snr_s, rng=rng)
    sigma = 10 ** (-snr_s / 20) / np.sqrt(2.0)
    print("table1, a target 20 dB louder 12 range bins from one at 20 dB: cycles listing the weak one")
    for kind in ("ca_cfar", "os_cfar"):
        listed = np.abs(target_list(x, rho, g, sigma, detection=kind).range_m - ranges[:, :1]) < g.range_resolution_m
        print(f"  {kind}: {listed.any(axis=1).mean():.3f}")
    _resolution(rng, c)


def _resolution(rng, c: int) -> None:
    """Two equal targets (20 dB each after integration, the same velocity) a given number of range bins apart:
    the share of cycles whose OS-CFAR list holds both (each within 0.4 spacing, at most half a cell, of its
    truth), and
    the share that lists the pair as one (a target within half a cell of the pair's span, not both resolved)."""

    g, m, _, _ = load_preset("table1")
    res = g.range_resolution_m
    snr_s = 20.0 - 10 * np.log10(m // 2)
    sigma = 10 ** (-snr_s / 20) / np.sqrt(2.0)
    print(f"table1, two equal targets at 20 dB, same velocity, OS-CFAR + ml, {c} cycles per spacing")
    print(f"{'spacing (bins)':>15}{'both listed':>13}{'as one':>13}")
    for bins in (0.5, 1.0, 1.5, 2.0, 3.0):
        rho = balanced_rows(rng, c, m)
        r0 = 0.3 * g.max_range_m + rng.uniform(-0.5, 0.5, (c, 1)) * res
        ranges = np.hstack([r0, r0 + bins * res])
        speeds = np.full((c, 2), 0.2 * g.max_velocity_mps)
        x = synth_beat(g, rho, ranges, speeds, snr_sample_db=snr_s, rng=rng)
        tl = target_list(x, rho, g, sigma, detection="os_cfar")
        tol = min(0.5, 0.4 * bins) * res                 # a target midway between the two matches neither
        near = np.abs(tl.range_m[:, :, None] - ranges[:, None, :]) < tol               # (C, K, 2)
        both = near.any(axis=1).all(axis=1)              # tol < spacing / 2: two different listed targets
        mid = ranges.mean(axis=1, keepdims=True)
        as_one = (np.abs(tl.range_m - mid) < (0.5 * bins + 0.5) * res).any(axis=1) & ~both
        print(f"{bins:>15g}{both.mean():>13.2f}{as_one.mean():>13.2f}")


def _migration(seed: int, c: int) -> None:
    import dataclasses


    base = scene_of("awr1642")
    g = Geometry.from_scene(base)
    car = base.targets[0]
    r_true, v_true = car.range_m, base.range_rate_mps(car)
    r_gate, v_gate = gates(g, base.n_chirps, abs(v_true))
    print(f"awr1642 car at {r_true:g} m closing at {-v_true:.1f} m/s, OS-CFAR pfa 1e-6 per cell, {c} cycles per row: "
          "without and with range-walk compensation (max_speed_mps 100); SNR: the listed cell's, after integration "
          "(median)")
    print(f"{'RCS':>9}{'SNR':>7}{'max speed':>11}{'Pd':>7}{'false/cycle':>13}{'range RMSE':>12}{'velocity RMSE':>15}"
          f"{'true alias':>12}")
    for rcs in (car.rcs_m2, car.rcs_m2 * 1e-3, car.rcs_m2 * 1e-4, car.rcs_m2 * 10 ** -4.5):
        scene = dataclasses.replace(base, targets=(dataclasses.replace(car, rcs_m2=rcs),))
        rng = np.random.default_rng(seed)
        rho = balanced_rows(rng, c, scene.n_chirps)
        x = simulate_cycles(scene, rho, rng).frames
        for speed in (0.0, 100.0):
            tl = target_list(x, rho, g, scene.sigma_n, detection="os_cfar", max_speed_mps=speed)
            hit, false, err_r, err_v, snr = 0, 0, [], [], []
            for i in range(c):
                k = tl.n_found[i]
                d, f = associate(tl.range_m[i, :k], tl.velocity_mps[i, :k], [r_true], [v_true], r_gate, v_gate,
                                 g.max_velocity_mps)
                hit, false = hit + int(d[0]), false + f
                if k:
                    j = int(np.argmin(np.abs(tl.range_m[i, :k] - r_true)))
                    err_r.append(tl.range_m[i, j] - r_true)
                    err_v.append(tl.velocity_mps[i, j] - v_true)
                    snr.append(tl.snr_db[i, j])
            err_r, err_v = np.asarray(err_r), np.asarray(err_v)
            alias = np.mean(np.abs(err_v) < g.max_velocity_mps) if err_v.size else float("nan")
            snr_db = np.median(snr) if snr else float("nan")
            print(f"{rcs:>6.2g} m2{snr_db:>4.0f} dB{speed:>7g} m/s{hit / c:>7.2f}{false / c:>13.2f}"
                  f"{np.sqrt(np.mean(err_r ** 2)):>10.3f} m"
                  f"{np.sqrt(np.mean(err_v ** 2)):>11.3f} m/s{alias:>12.2f}")
