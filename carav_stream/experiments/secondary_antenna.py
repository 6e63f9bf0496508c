"""The paper's Section V.G (Figures 6-8) and the "harmless misses" claim (`carav experiment secondary-antenna`; its
command line in carav_stream/cli/experiment/secondary_antenna.py).

Scene: table1 (the car at 43 m), plus an attacker:

    secondary_antenna   a physical FMCW transmitter (victim's sweep, synchronised) at --antenna-range, moving
                        at 50 km/h, received one way; its transmit power is set from a target RARMS
                        (sigma_a / sigma_n) with SecondaryAntennaAttacker.equivalent_rarms, so the three
                        levels are comparable with the paper's RARMS axis
    ghost               chirp-synchronised spoofer: a replica of the victim's chirp that looks like a target at
                        --ghost-range moving at 50 km/h, at the same RARMS levels

Power levels (RARMS): low 0.3 (PF and PM curves overlap), medium 1.05 (close: the missed fraction at
eta = 1.5 is large), high 3.0 (disjoint). Per simulated cycle: Q of the CARAV detector (detect(frames, rho,
sigma_n, eta)) and the range error |R_hat - 43 m| of the strongest target by MUSIC (carav_stream.estimate,
active chirps only); and whether a false target (farther than one range resolution from the car among
the four strongest range-Doppler peaks, stronger relative to the strongest peak than anything the clean
cycles show, times FALSE_TARGET_MARGIN) is reported. A missed attack is one with Q < eta. The claim
"every missed attack is harmless" holds at a power level when the largest range error among missed attacks is below the
range resolution (1 m) -- and, as a stricter reading, when no missed attack plants a false target.
"""
from __future__ import annotations

from collections.abc import Callable

import numpy as np

from carav_stream.core.units import KMH
from carav_stream.detect.detector import detect
from carav_stream.estimate import Geometry, estimate
from carav_stream.experiments.errors import ExperimentError
from carav_stream.experiments.reporting import Tally
from carav_stream.radar.attackers import make_attacker
from carav_stream.radar.scene_loader import load_scene
from carav_stream.radar.synth import simulate_cycles

__all__ = ["experiment", "json_ready", "plot", "POWER_RARMS", "TRUE_RANGE_M", "simulate_level"]

POWER_RARMS = {"low": 0.3, "medium": 1.05, "high": 3.0}

TRUE_RANGE_M = 43.0
FALSE_TARGET_MARGIN = 2.0
"""A far peak is a false target when its power relative to the strongest peak exceeds the largest such ratio
seen in the clean cycles (the car's own sidelobes and migration residue) times this margin (+3 dB)."""


def _make_attacker(kind: str, scene, rarms: float, antenna_range_m: float, ghost_range_m: float):
    if kind == "secondary_antenna":
        probe = make_attacker(kind, scene, range_m=antenna_range_m, velocity_mps=50.0 * KMH, tx_power_w=1e-3)
        p_w = 1e-3 * (rarms / probe.equivalent_rarms()) ** 2
        return make_attacker(kind, scene, range_m=antenna_range_m, velocity_mps=50.0 * KMH, tx_power_w=p_w), p_w
    return make_attacker(kind, scene, range_m=ghost_range_m, velocity_mps=50.0 * KMH, rarms=rarms), None


def _cycle_metrics(frames, rho, scene, geometry, eta, method):
    q = detect(frames, rho, scene.sigma_n, eta).q
    est = estimate(frames, rho, geometry, method=method)
    err = np.abs(est.range_m[:, 0] - TRUE_RANGE_M)
    # strongest peak farther than a resolution cell from the car, relative to the strongest peak, among the
    # four strongest range-Doppler peaks found by RELAX-style sequential search (ML-refined)
    multi = estimate(frames, rho, geometry, method="ml", n_targets=4)
    power = multi.amplitude ** 2
    far = np.abs(multi.range_m - TRUE_RANGE_M) > geometry.range_resolution_m
    rel = np.where(far, power, 0.0).max(axis=1) / np.maximum(np.nanmax(power, axis=1), 1e-300)
    return q, err, np.nan_to_num(rel)


def simulate_level(kind: str, level: str, scene, geometry, rho, rng_seed, *, eta: float, method: str,
                   antenna_range_m: float, ghost_range_m: float) -> dict:
    """Q, range error and false-target flags for one attacker and power level (attacked cycles)."""
    rarms = POWER_RARMS[level]
    attacker, p_w = _make_attacker(kind, scene, rarms, antenna_range_m, ghost_range_m)
    ss = np.random.SeedSequence(rng_seed)
    r_noise, r_att = (np.random.default_rng(s) for s in ss.spawn(2))
    cyc = simulate_cycles(scene, rho, r_noise, attacker=attacker, rng_attack=r_att)
    q, err, far_rel = _cycle_metrics(cyc.frames, rho, scene, geometry, eta, method)
    return {"attacker": kind, "power": level, "rarms": rarms, "tx_power_w": p_w, "q": q, "range_error_m": err,
            "far_rel": far_rel, "fidelity": cyc.fidelity}


def _summary(res: dict, q0: np.ndarray, eta: float, resolution_m: float, ft_threshold: float) -> dict:
    q, err = res["q"], res["range_error_m"]
    ft = res["far_rel"] > ft_threshold
    missed = q < eta
    max_missed = float(np.max(err[missed])) if missed.any() else None
    return {
        "attacker": res["attacker"], "power": res["power"], "rarms": res["rarms"], "tx_power_w": res["tx_power_w"],
        "n_trials": int(q.size), "pf": float(np.mean(q0 >= eta)), "pm": float(np.mean(missed)),
        "n_missed": int(missed.sum()), "max_missed_range_error_m": max_missed,
        "median_detected_range_error_m": float(np.median(err[~missed])) if (~missed).any() else None,
        "missed_false_target_rate": float(np.mean(ft[missed])) if missed.any() else None,
        "range_resolution_m": resolution_m,
        "harmless_range": (max_missed is None) or (max_missed < resolution_m),
        "harmless_strict": (max_missed is None) or (max_missed < resolution_m and not ft[missed].any()),
    }


def plot(results: list[dict], q0: np.ndarray, eta: float, path) -> None:
    """PF and PM over eta per attacker and power level (the levels of experiment(): "q" and "range_error_m" per
    cycle), and Q against the range error, into the PNG file `path`."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    grid = np.linspace(0.9, max(4.0, float(np.max([r["q"].max() for r in results])) * 1.05), 400)
    pf = np.array([np.mean(q0 >= e) for e in grid])
    fig, axes = plt.subplots(len(results), 2, figsize=(11, 3.2 * len(results)), squeeze=False)
    for i, r in enumerate(results):
        pm = np.array([np.mean(r["q"] < e) for e in grid])
        ax = axes[i, 0]
        ax.plot(grid, pf, label="PF(eta)")
        ax.plot(grid, pm, label="PM(eta)")
        ax.axvline(eta, color="k", ls="--", lw=0.8, label=f"eta = {eta:g}")
        ax.set(xlabel="threshold eta (no unit)", ylabel="probability",
               title=f"{r['attacker']}, {r['power']} (RARMS {r['rarms']:g}): PF and PM")
        ax.legend(fontsize=8)
        ax = axes[i, 1]
        ax.semilogx(np.maximum(r["range_error_m"], 1e-4), r["q"], ".", ms=3)
        ax.axhline(eta, color="k", ls="--", lw=0.8, label=f"Q = {eta:g}")
        ax.axvline(1.0, color="r", ls=":", lw=0.8, label="range resolution")
        ax.set(xlabel="range error [m]", ylabel="Q (no unit)", title="Q against range error: missed below the line")
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def experiment(*, power: str, trials: int, attacker: str, eta: float, method: str, antenna_range_m: float,
               ghost_range_m: float, snr_db: float | None, seed: int,
               partial: Callable[[str, dict], None] | None = None,
               progress: Callable[[int, int], None] | None = None) -> dict:
    """The clean reference and every level of `attacker` ("secondary_antenna", "ghost" or "both") at `power` ("low",
    "medium", "high" or "all"), `trials` cycles each: {"snr_db", "eta", "method", "trials",
    "false_target_threshold", "clean": {"pf", "q", "range_error_m"}, "levels": [_summary's figures with "q",
    "range_error_m" and "false_target" per cycle]}, the per-cycle values as numpy arrays (json_ready() makes them
    lists). partial("clean", {"snr_db", "pf", "range_error_median_m", "range_error_max_m",
    "false_target_threshold"}) once the clean cycles are judged, partial("level", its entry) as each level is done;
    progress(cycles done, cycles in all) as they are judged."""
    scene = load_scene("table1", {"snr_db": snr_db} if snr_db is not None else None)
    geometry = Geometry.from_scene(scene)
    resolution = float(scene.range_resolution_m)
    rng = np.random.default_rng(seed)
    n = int(trials)
    if n < 1:
        raise ExperimentError(f"trials must be >= 1, got {n}")
    keys = rng.random((n, scene.n_chirps))
    rho = np.argsort(np.argsort(keys, axis=1), axis=1) < scene.n_chirps // 2
    clean = simulate_cycles(scene, rho, np.random.default_rng(rng.integers(2**63)))
    q0, err0, rel0 = _cycle_metrics(clean.frames, rho, scene, geometry, eta, method)
    ft_threshold = FALSE_TARGET_MARGIN * float(np.max(rel0))
    out = {"snr_db": float(scene.snr_db()), "eta": eta, "method": method, "trials": n,
           "false_target_threshold": ft_threshold, "clean": {
               "pf": float(np.mean(q0 >= eta)), "q": q0, "range_error_m": err0}, "levels": []}
    kinds = ("secondary_antenna", "ghost") if attacker == "both" else (attacker,)
    levels = tuple(POWER_RARMS) if power == "all" else (power,)
    tally = Tally(n * (1 + len(kinds) * len(levels)), progress)
    tally(n)
    if partial is not None:
        partial("clean", {"snr_db": out["snr_db"], "pf": out["clean"]["pf"],
                           "range_error_median_m": float(np.median(err0)), "range_error_max_m": float(np.max(err0)),
                           "false_target_threshold": ft_threshold})
    for kind in kinds:
        for level in levels:
            res = simulate_level(kind, level, scene, geometry, rho, int(rng.integers(2**63)), eta=eta, method=method,
                                 antenna_range_m=antenna_range_m, ghost_range_m=ghost_range_m)
            entry = {**_summary(res, q0, eta, resolution, ft_threshold), "q": res["q"],
                     "range_error_m": res["range_error_m"], "false_target": res["far_rel"] > ft_threshold}
            out["levels"].append(entry)
            tally(n)
            if partial is not None:
                partial("level", entry)
    return out


def json_ready(result: dict) -> dict:
    """experiment()'s result with its per-cycle arrays as lists."""
    clean = result["clean"]
    return {**result, "clean": {**clean, "q": clean["q"].tolist(), "range_error_m": clean["range_error_m"].tolist()},
            "levels": [{**lv, "q": lv["q"].tolist(), "range_error_m": lv["range_error_m"].tolist(),
                        "false_target": lv["false_target"].tolist()} for lv in result["levels"]]}
