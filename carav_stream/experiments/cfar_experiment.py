"""The radar's target detection measured against its design (carav_stream/firmware/cfar.py; `carav experiment cfar`,
its command line in carav_stream/cli/experiment/cfar.py).

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

import dataclasses
from collections.abc import Callable

import numpy as np
import scipy.signal

from carav_stream.detect.rdmap import rd_power
from carav_stream.estimate.crlb import fmcw_crlb
from carav_stream.estimate.geometry import Geometry
from carav_stream.estimate.tones import centroid_ranges, synth_beat
from carav_stream.experiments.reporting import Tally, load_preset
from carav_stream.firmware import cfar
from carav_stream.firmware.target_list import associate, gates, target_list
from carav_stream.radar.activation import balanced_rows
from carav_stream.radar.scene_loader import load_scene
from carav_stream.radar.streams import scene_of
from carav_stream.radar.synth import simulate_cycles

__all__ = ["cfar_experiment", "PARTS"]

PARTS = ("false_alarms", "detection", "refined", "two_targets", "resolution", "migration")   # in the order run

DETECTION_SNR_DB = (5.0, 10.0, 15.0, 20.0, 25.0)
REFINED_PRESETS, REFINED_SNR_DB = ("table1", "awr1642"), (10.0, 20.0, 30.0)
RESOLUTION_BINS = (0.5, 1.0, 1.5, 2.0, 3.0)
MIGRATION_RCS_SCALE, MIGRATION_SPEEDS_MPS = (1.0, 1e-3, 1e-4, 10 ** -4.5), (0.0, 100.0)


def cfar_experiment(preset: str, trials: int, pfa: float, seed: int,
                    partial: Callable[[str, dict], None] | None = None,
                    progress: Callable[[int, int], None] | None = None, last: str = PARTS[-1]) -> dict:
    """Every part of the experiment (the module docstring) by name, in the order of PARTS: false_alarms, detection
    (1, 2), refined, two_targets, resolution (3), migration (4); each a dict of its settings and "rows". partial(name,
    part) as each part is done, progress(cycles done, cycles in all) as they are measured. `trials` cycles per
    measurement of parts 1 and 2 (a quarter, at least 40, for part 3; at most 64 for part 4), `pfa` the design rate
    per cell of parts 1 and 2. `last`: the parts up to this one only; they share the random stream in their order,
    so each has the figures it has in the whole experiment."""
    wanted = PARTS[:PARTS.index(last) + 1]
    scene = load_scene(preset)
    rng = np.random.default_rng(seed)
    c, c_list, c_walk = trials, max(40, trials // 4), min(trials, 64)
    cycles = {"false_alarms": c, "detection": c * len(DETECTION_SNR_DB),
              "refined": c_list * len(REFINED_PRESETS) * len(REFINED_SNR_DB), "two_targets": c_list,
              "resolution": c_list * len(RESOLUTION_BINS),
              "migration": c_walk * len(MIGRATION_RCS_SCALE) * len(MIGRATION_SPEEDS_MPS)}
    tally = Tally(sum(cycles[name] for name in wanted), progress)
    runs = {"false_alarms": lambda: _false_alarms(scene, rng, c, pfa, seed, tally),
            "detection": lambda: _detection(scene, rng, c, pfa, tally),
            "refined": lambda: _refined_list(rng, c_list, tally),
            "two_targets": lambda: _two_targets(rng, c_list, tally),
            "resolution": lambda: _resolution(rng, c_list, tally),
            "migration": lambda: _migration(seed, c_walk, tally)}
    parts: dict[str, dict] = {}
    for name in wanted:                  # in this order: they share rng
        parts[name] = runs[name]()
        if partial is not None:
            partial(name, parts[name])
    return parts


def _frames(rng, c, m, n, iq):
    x = rng.standard_normal((c, m, n))
    return (x + 1j * rng.standard_normal((c, m, n))) / np.sqrt(2) if iq else x


def _false_alarms(scene, rng, c: int, pfa: float, seed: int, tick: Tally) -> dict:
    """Noise-only cycles: the share of map cells above the CA- and OS-CFAR thresholds, the targets listed per cycle."""
    m, n, iq = scene.n_chirps, scene.n_samples, scene.iq
    rho = balanced_rows(rng, c, m)
    p = rd_power(_frames(rng, c, m, n, iq), rho, 1.0)
    rows = []
    for kind in ("ca", "os"):
        hit = np.mean(p > cfar.cfar_threshold(p, pfa=pfa, kind=kind))
        listed = cfar.detect_targets(p, rho, pfa=pfa, kind=kind, max_targets=64).n_found.mean()
        rows.append({"kind": kind, "above": float(hit), "listed_per_cycle": float(listed)})
    tick(c)
    return {"scene": scene.name, "n_chirps": m, "n_range_cells": p.shape[2], "cells": p.shape[1] * p.shape[2],
            "cycles": c, "seed": seed, "pfa": pfa, "rows": rows}


def _detection(scene, rng, c: int, pfa: float, tick: Tally) -> dict:
    """A Swerling 1 target centred on a cell: CA-CFAR's Pd per SNR beside the textbook curve."""
    m, n, iq = scene.n_chirps, scene.n_samples, scene.iq
    w = scipy.signal.windows.hann(n, sym=False)
    gain = (w.sum() ** 2 / (w @ w))                                    # coherent gain over noise gain, per chirp
    alpha, n_train = cfar.ca_alpha(pfa, 16), 16
    k_bin, l_bin = n // 5, m // 8
    t, mm = np.arange(n), np.arange(m)[:, None]
    rows = []
    for snr_db in DETECTION_SNR_DB:
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
        thr = cfar.cfar_threshold(q, pfa=pfa, kind="ca")
        pd = np.mean(q[:, l_bin, col] > thr[:, l_bin, col])
        rows.append({"snr_db": snr_db, "pd": float(pd),
                     "pd_textbook": float((1 + alpha / (n_train * (1 + snr))) ** -n_train)})
        tick(c)
    return {"range_bin": k_bin, "doppler_bin": l_bin, "cycles": c, "rows": rows}


def _refined_list(rng, c: int, tick: Tally) -> dict:
    """One target per preset and SNR through the refined list (ml): range and velocity RMSE over the CRLB."""
    rows = []
    for preset in REFINED_PRESETS:
        g, m, r0, v0 = load_preset(preset)
        vmax = g.max_velocity_mps
        for snr_db in REFINED_SNR_DB:
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
            rmse_r = np.sqrt(np.nanmean(err_r ** 2) / np.mean(bound["range_m"] ** 2))
            rmse_v = np.sqrt(np.nanmean(err_v ** 2) / np.mean(bound["velocity_mps"] ** 2))
            rows.append({"preset": preset, "snr_db": snr_db, "range_rmse_over_crlb": float(rmse_r),
                         "velocity_rmse_over_crlb": float(rmse_v), "listed_per_cycle": float(tl.n_found.mean())})
            tick(c)
    return {"cycles": c, "rows": rows}


def _two_targets(rng, c: int, tick: Tally) -> dict:
    """table1, a target 20 dB louder 12 range bins from one at 20 dB: the share of cycles listing the weak one."""
    g, m, r0, _ = load_preset("table1")
    rho = balanced_rows(rng, c, m)
    ranges = np.tile([0.3 * g.max_range_m, 0.3 * g.max_range_m + 12 * g.range_resolution_m], (c, 1))
    speeds = np.tile([0.2 * g.max_velocity_mps, -0.4 * g.max_velocity_mps], (c, 1))
    snr_s = 20.0 - 10 * np.log10(m // 2)
    x = synth_beat(g, rho, ranges, speeds, amplitudes=np.array([1.0, 10.0]), snr_sample_db=snr_s, rng=rng)
    sigma = 10 ** (-snr_s / 20) / np.sqrt(2.0)
    rows = []
    for kind in ("ca_cfar", "os_cfar"):
        listed = np.abs(target_list(x, rho, g, sigma, detection=kind).range_m - ranges[:, :1]) < g.range_resolution_m
        rows.append({"detection": kind, "weak_listed": float(listed.any(axis=1).mean())})
    tick(c)
    return {"cycles": c, "rows": rows}


def _resolution(rng, c: int, tick: Tally) -> dict:
    """Two equal targets (20 dB each after integration, the same velocity) a given number of range bins apart:
    the share of cycles whose OS-CFAR list holds both (each within 0.4 spacing, at most half a cell, of its
    truth), and the share that lists the pair as one (a target within half a cell of the pair's span, not both
    resolved)."""
    g, m, _, _ = load_preset("table1")
    res = g.range_resolution_m
    snr_s = 20.0 - 10 * np.log10(m // 2)
    sigma = 10 ** (-snr_s / 20) / np.sqrt(2.0)
    rows = []
    for bins in RESOLUTION_BINS:
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
        rows.append({"spacing_bins": bins, "both_listed": float(both.mean()), "as_one": float(as_one.mean())})
        tick(c)
    return {"cycles": c, "rows": rows}


def _migration(seed: int, c: int, tick: Tally) -> dict:
    """The awr1642 car and weaker copies through the signal chain: the OS-CFAR list without and with range-walk
    compensation."""
    base = scene_of("awr1642")
    g = Geometry.from_scene(base)
    car = base.targets[0]
    r_true, v_true = car.range_m, base.range_rate_mps(car)
    r_gate, v_gate = gates(g, base.n_chirps, abs(v_true))
    rows = []
    for rcs in (car.rcs_m2 * k for k in MIGRATION_RCS_SCALE):
        scene = dataclasses.replace(base, targets=(dataclasses.replace(car, rcs_m2=rcs),))
        rng = np.random.default_rng(seed)
        rho = balanced_rows(rng, c, scene.n_chirps)
        x = simulate_cycles(scene, rho, rng).frames
        for speed in MIGRATION_SPEEDS_MPS:
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
            rows.append({"rcs_m2": rcs, "snr_db": float(np.median(snr)) if snr else float("nan"),
                         "max_speed_mps": speed, "pd": hit / c, "false_per_cycle": false / c,
                         "range_rmse_m": float(np.sqrt(np.mean(err_r ** 2))),
                         "velocity_rmse_mps": float(np.sqrt(np.mean(err_v ** 2))),
                         "true_alias": float(np.mean(np.abs(err_v) < g.max_velocity_mps)) if err_v.size
                         else float("nan")})
            tick(c)
    return {"range_m": r_true, "closing_mps": -v_true, "cycles": c, "rows": rows}
