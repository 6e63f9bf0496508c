"""Beyond the paper, for `carav reproduce`: every attacker model, nuisances, the ghost, reactive repeaters, ramps.

Each function runs its experiment through the radar signal chain and returns markdown lines (and fills `data` with
the numbers for the JSON output); the *_NOTES strings explain the tables.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from carav_stream.detect import opt_in
from carav_stream.detect.detector import PAPER_ETA, detect
from carav_stream.detect.rdmap import rd_power
from carav_stream.detect.stats import cfar_eta_closed_form, pf_pm_closed_form
from carav_stream.experiments.latency import window_start
from carav_stream.experiments.reporting import log, radar_scene, radar_source, rate
from carav_stream.firmware import cfar
from carav_stream.montecarlo.engine import simulate_q
from carav_stream.radar.activation import balanced_rows
from carav_stream.radar.attackers import make_attacker
from carav_stream.radar.synth import simulate_cycles

__all__ = ["attacker_table", "nuisance_table", "ghost_section", "reactive_and_ramp", "calibration_risk",
           "ATTACKER_NOTES", "NUISANCE_NOTES", "GHOST_NOTES", "CALIBRATION_NOTES"]



ATTACK_ROWS = [  # (label, kind, activation, params, rarms list)
    ("random", "random", "seeded", {}, [0.3, 1.0, 1.2, 3.0]),
    ("smart", "smart", "seeded", {}, [0.3, 1.0, 1.2, 3.0]),
    ("ramp 0.1 -> RARMS over the run", "ramp", "seeded", {"rarms_start": 0.1}, [0.3, 1.0, 1.2, 3.0]),
    ("lfsr_predictor vs LFSR activation", "lfsr_predictor", "lfsr", {}, [0.3, 1.0, 1.2, 3.0]),
    ("lfsr_predictor vs uniformly random activation (the secure source's law, seeded)", "lfsr_predictor",
     "seeded", {}, [0.3, 1.0, 1.2, 3.0]),
    ("ghost at 25 m", "ghost", "seeded", {"range_m": 25.0}, [0.3, 1.0, 1.2, 3.0]),
    ("reactive repeater 30 m, 100 ns", "reactive", "seeded", {}, [0.3, 1.0, 1.2, 3.0]),
    ("secondary_antenna 30 m, 50 km/h", "secondary_antenna", "seeded", {}, [0.3, 1.0, 1.2, 3.0]),
]


def attacker_table(args, data: dict) -> list[str]:
    scene = radar_scene("table1")
    n = args.beyond_trials
    dof = scene.n_samples * (2 if scene.iq else 1)
    eta_cfar = cfar_eta_closed_form(1e-6, n_chirps=scene.n_chirps, dof=dof)
    rows = [f"Table I scene, {n} cycles per cell, full samples, radar chain. eta_CFAR = {eta_cfar:.4f} is the "
            "closed-form threshold for PF = 1e-6 per cycle (Gaussian noise, D0 part exact).", "",
            "| attacker | RARMS | detected at eta = 1.5 | detected at eta_CFAR | median Q | alarms from D1 |",
            "|---|---:|---|---|---:|---:|"]
    out = []
    for label, kind, act, params, rl in ATTACK_ROWS:
        for r in rl:
            p = dict(params)
            if kind == "ramp":
                p["n_ramp_cycles"] = n
            src = radar_source(scene, activation=act, attack_params={kind: p})
            try:
                qd = simulate_q(src, kind, r, n, np.random.SeedSequence([args.seed, len(out)]), method="samples")
            except Exception as exc:   # report, do not hide, a failing attacker
                rows.append(f"| {label} | {r:g} | error: {exc} | | | |")
                continue
            k15 = int(np.sum(qd.q >= PAPER_ETA))
            kc = int(np.sum(qd.q >= eta_cfar))
            d1 = float(np.mean(qd.by_d1[qd.q >= PAPER_ETA])) if k15 else 0.0
            out.append({"attacker": label, "kind": kind, "rarms": r, "detected_1_5": k15, "detected_cfar": kc,
                        "trials": n, "median_q": float(np.median(qd.q)), "d1_share": d1})
            rows.append(f"| {label} | {r:g} | {rate(k15, n)} | {rate(kc, n)} | {np.median(qd.q):.3f} | {d1:.2f} |")
            log(args, f"attacker {label} rarms {r}: {k15}/{n}")
    data["attackers"] = {"eta_cfar": eta_cfar, "rows": out}
    return rows


NUISANCES = [  # (label, scene overrides, detector sigma factor)
    ("ideal: Swerling 0 target, calibrated sigma_n", {}, 1.0),
    ("Swerling 1 target (per cycle), SNR 0 dB", {"swerling": 1}, 1.0),
    ("Swerling 2 target (per chirp), SNR 0 dB", {"swerling": 2}, 1.0),
    ("Swerling 1 target, SNR 20 dB", {"swerling": 1, "snr_db": 20.0}, 1.0),
    ("Swerling 2 target, SNR 20 dB", {"swerling": 2, "snr_db": 20.0}, 1.0),
    ("noise drift: true sigma_n 5 % above calibration", {}, 1 / 1.05),
    ("noise drift: true sigma_n 20 % above calibration", {}, 1 / 1.2),
    ("noise drift: true sigma_n 50 % above calibration", {}, 1 / 1.5),
    ("noise drift: true sigma_n 20 % below calibration", {}, 1 / 0.8),
    ("ADC clipping: full scale 3 dB above signal RMS", {"adc_headroom_db": 3.0}, 1.0),
    ("ADC clipping: full scale 0 dB, SNR 20 dB", {"adc_headroom_db": 0.0, "snr_db": 20.0}, 1.0),
]


def nuisance_table(args, data: dict) -> list[str]:
    n = max(args.beyond_trials, 1000)
    rows = ["| condition | clipped samples/cycle | false alarms at eta = 1.5 | at eta_CFAR | from D1 | median Q |",
            "|---|---:|---|---|---:|---:|"]
    out = []
    for i, (label, over, factor) in enumerate(NUISANCES):
        over = dict(over)
        sw = over.pop("swerling", None)
        if sw is not None:
            over["targets"] = [{"range_m": 43.0, "velocity_kmh": 96.0, "rcs_m2": 100.0, "swerling": sw}]
        scene = radar_scene("table1", **over)
        dof = scene.n_samples
        eta_cfar = cfar_eta_closed_form(1e-6, n_chirps=scene.n_chirps, dof=dof)
        src = radar_source(scene, detector_sigma_n=scene.sigma_n * factor)
        qd = simulate_q(src, "none", 0.0, n, np.random.SeedSequence([args.seed, 100 + i]), method="samples")
        clipped = src._job["clipped"] / n if src._job else 0.0
        k15, kc = int(np.sum(qd.q >= PAPER_ETA)), int(np.sum(qd.q >= eta_cfar))
        alarms = qd.q >= min(PAPER_ETA, eta_cfar)
        d1 = float(np.mean(qd.by_d1[alarms])) if alarms.any() else float("nan")
        out.append({"condition": label, "false_alarms_1_5": k15, "false_alarms_cfar": kc, "trials": n,
                    "d1_share": d1, "median_q": float(np.median(qd.q)), "clipped_per_cycle": clipped})
        d1_txt = "-" if np.isnan(d1) else f"{d1:.2f}"
        rows.append(f"| {label} | {clipped:.1f} | {rate(k15, n)} | {rate(kc, n)} | {d1_txt} | "
                    f"{np.median(qd.q):.3f} |")
        log(args, f"nuisance {label}: {k15}/{n}")
    data["nuisances"] = out
    return rows


def ghost_section(args, fig_dir: Path, data: dict) -> list[str]:
    import scipy.fft


    scene = radar_scene("table1")
    n = args.beyond_trials
    rng = np.random.default_rng([args.seed, 7])
    rho = balanced_rows(rng, n, scene.n_chirps)
    null = simulate_cycles(scene, rho, rng)
    sp0 = opt_in.spectral_silent_test(null.frames, rho, scene.sigma_n, pf=1e-6)
    in0 = opt_in.integrated_silent_test(null.frames, rho, scene.sigma_n, pf=1e-6)
    co0 = opt_in.coherent_silent_test(null.frames, rho, scene.sigma_n, pf=1e-6)
    n_bins = (scene.n_samples - 1) // 2
    res_m = scene.range_resolution_m
    rows = [f"Table I scene (target at 43 m, SNR 0 dB per sample), ghost placed at 25 m, {n} cycles per row. The "
            "ghost peak SNR is |X_b|^2 / (N_s sigma_n^2) at the ghost's bin of one silent chirp (where the ghost is "
            "alone), median over the silent chirps and cycles. Both spectral tests at PF = 1e-6 per cycle with exact "
            f"thresholds: single-chirp {sp0.threshold:.1f} ({10 * np.log10(sp0.threshold):.1f} dB) over "
            f"{sp0.n_bins_tested} bins, integrated over the {scene.n_chirps // 2} silent chirps {in0.threshold:.1f} "
            f"(a mean of {in0.threshold / (scene.n_chirps // 2):.2f} per chirp) over {in0.n_bins_tested} bins; the "
            f"coherent test on the silent chirps' range-Doppler map {co0.threshold:.1f} over {co0.n_bins_tested} "
            f"cells (union bound); on attack-free cycles they raised {rate(int(sp0.alarm.sum()), n)}, "
            f"{rate(int(in0.alarm.sum()), n)} and {rate(int(co0.alarm.sum()), n)} false alarms. 'Reported by the "
            "radar': its own target detection (CA-CFAR at 1e-6 per cell on the active chirps' range-Doppler map, "
            "`carav_stream.firmware.cfar`) lists a target within one range bin of the ghost's.", "",
            "| ghost RARMS | raw RMS above noise | median Q | C(1.5) alarms | ghost peak SNR per silent chirp (median) "
            "| strongest-peak range estimate (true target 43 m) | single-chirp spectral test | integrated spectral "
            "test | coherent silent-chirp test | reported by the radar | reported, and no test alarmed |",
            "|---:|---:|---:|---|---:|---|---|---|---|---|---|"]
    out = []
    ghost_bin = int(round(25.0 / res_m))
    for r in GHOST_RARMS:
        att = make_attacker("ghost", scene, rarms=r, range_m=25.0)
        cyc = simulate_cycles(scene, rho, rng, attacker=att, rng_attack=rng)
        det = detect(cyc.frames, rho, scene.sigma_n)
        sp = opt_in.spectral_silent_test(cyc.frames, rho, scene.sigma_n, pf=1e-6)
        it = opt_in.integrated_silent_test(cyc.frames, rho, scene.sigma_n, pf=1e-6)
        co = opt_in.coherent_silent_test(cyc.frames, rho, scene.sigma_n, pf=1e-6)
        found = cfar.detect_targets(rd_power(cyc.frames, rho, scene.sigma_n), rho, pfa=1e-6)
        reported = np.any(np.abs(found.range_bin + 1 - ghost_bin) <= 1, axis=1)     # map bin j is FFT bin j + 1
        unseen = reported & ~(det.alarm | sp.alarm | it.alarm | co.alarm)
        silent = cyc.frames[~rho].reshape(n, scene.n_chirps // 2, scene.n_samples).astype(np.float64)
        at_ghost = np.abs(scipy.fft.rfft(silent, axis=-1)[..., ghost_bin]) ** 2 / (scene.n_samples * scene.sigma_n ** 2)
        snr_db = 10 * np.log10(np.median(at_ghost))
        ka = int(det.alarm.sum())
        # a naive single-target estimator: strongest bin of the active chirps' summed range spectra, per cycle
        act = cyc.frames[rho].reshape(n, scene.n_chirps // 2, scene.n_samples).astype(np.float64)
        spec = np.sum(np.abs(scipy.fft.rfft(act, axis=-1)[..., 1: n_bins + 1]) ** 2, axis=1)
        est_m = (np.argmax(spec, axis=-1) + 1) * res_m
        wrong = int(np.sum(np.abs(est_m - 43.0) > 2 * res_m))
        out.append({"rarms": r, "median_q": float(np.median(det.q)), "alarms": ka, "trials": n,
                    "ghost_peak_snr_db": snr_db, "spectral_detections": int(sp.alarm.sum()),
                    "integrated_detections": int(it.alarm.sum()), "coherent_detections": int(co.alarm.sum()),
                    "reported_by_radar": int(reported.sum()), "reported_unseen": int(unseen.sum()),
                    "estimator_wrong": wrong, "estimator_median_m": float(np.median(est_m))})
        rows.append(f"| {r:g} | {10 * np.log10(1 + r * r):.3f} dB | {np.median(det.q):.3f} | {rate(ka, n)} | "
                    f"{snr_db:.1f} dB | median {np.median(est_m):.1f} m, off the car in {rate(wrong, n)} | "
                    + " | ".join(rate(int(v.sum()), n) for v in (sp.alarm, it.alarm, co.alarm, reported, unseen))
                    + " |")
    rows += ["", ghost_notes(out, n), ""]
    data["ghost"] = {"rows": out, "spectral_null_alarms": int(sp0.alarm.sum()), "threshold": sp0.threshold,
                     "integrated_null_alarms": int(in0.alarm.sum()), "integrated_threshold": in0.threshold}
    _plot_ghost(scene, fig_dir, rng)
    _plot_ghost_pm(out, fig_dir)
    rows += ["", "![Range spectrum of a silent chirp with a ghost at RARMS 0.5]"
                 f"({args.figure_link}/repro_ghost_spectrum.png)", "",
             "![PM against ghost RARMS for each detector, with the radar's reporting threshold]"
             f"({args.figure_link}/repro_ghost_pm.png)"]
    return rows


def _plot_ghost_pm(out: list[dict], fig_dir: Path) -> None:
    """PM of every detector against the ghost's RARMS (log axis), the radar's reporting probability beside it and
    a line where the radar (CFAR) first reports the ghost in at least half the cycles."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    r = np.array([row["rarms"] for row in out])
    n = np.array([row["trials"] for row in out], dtype=float)
    fig, ax = plt.subplots(figsize=(8, 4.2))
    series = (("alarms", "C(1.5), the paper's RMS detector"), ("spectral_detections", "single-chirp spectral"),
              ("integrated_detections", "integrated spectral"), ("coherent_detections", "coherent silent-chirp"))
    for key, label in series:
        ax.semilogx(r, 1 - np.array([row[key] for row in out]) / n, "o-", ms=4, label=f"PM, {label}")
    reported = np.array([row["reported_by_radar"] for row in out]) / n
    ax.semilogx(r, reported, "k--", lw=1, label="share of cycles the radar reports the ghost in")
    first = next((x for x, share in zip(r, reported) if share >= 0.5), None)
    if first is not None:
        ax.axvline(first, color="r", ls=":", lw=1.2, label=f"radar reports it in >= 50 % of cycles (RARMS {first:g})")
    ax.set(xlabel="ghost RARMS (attack RMS over noise RMS, no unit)", ylabel="probability",
           title="Ghost at 25 m on Table I: misses of each detector (PF 1e-6 per cycle; C at eta 1.5)")
    ax.set_ylim(-0.03, 1.03)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="center left")
    fig.tight_layout()
    fig.savefig(fig_dir / "repro_ghost_pm.png", dpi=110)
    plt.close(fig)


def _plot_ghost(scene, fig_dir: Path, rng) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import scipy.fft


    rho = balanced_rows(rng, 1, scene.n_chirps)
    att = make_attacker("ghost", scene, rarms=0.5, range_m=25.0)
    cyc = simulate_cycles(scene, rho, rng, attacker=att, rng_attack=rng)
    silent = cyc.frames[0][~rho[0]][0].astype(np.float64)
    active = cyc.frames[0][rho[0]][0].astype(np.float64)
    f = np.arange(scene.n_samples // 2) * scene.range_resolution_m
    norm = scene.n_samples * scene.sigma_n ** 2
    fig, ax = plt.subplots(figsize=(8, 3.6))
    for x, lab in ((active, "active chirp (target 43 m + ghost)"), (silent, "silent chirp (ghost alone)")):
        p = np.abs(scipy.fft.rfft(x)[: f.size]) ** 2 / norm
        ax.plot(f, 10 * np.log10(p + 1e-12), lw=0.8, label=lab)
    ax.set_xlim(0, 80)
    ax.set_xlabel("range (m)")
    ax.set_ylabel("bin power / noise (dB)")
    ax.set_title("Ghost at RARMS 0.5 (raw RMS +1 dB, Q < 1.5): a 20+ dB peak after the range FFT")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(fig_dir / "repro_ghost_spectrum.png", dpi=110)
    plt.close(fig)


def reactive_and_ramp(args, data: dict) -> list[str]:
    scene = radar_scene("table1")
    n0 = 1000
    rng = np.random.default_rng([args.seed, 8])
    rho = balanced_rows(rng, n0, scene.n_chirps)
    first = window_start(scene)
    rows = [f"**Spill test** (`opt_in.spill_test`, PF = 1e-6 exact): range-bin power of the silent slots after "
            f"active ones, samples {first}.. (after the longest round trip the receiver passes), summed over those "
            "slots. Reactive repeater at 30 m, latency 100 ns (inside that round trip: the test's blind zone) and "
            "5 us (its reply spills into the window); docs/DETECTION.md, `carav experiment latency`.", "",
            "| RARMS | latency | C(1.5) detections | spill-test detections |", "|---:|---:|---|---|"]
    out = []
    n = args.beyond_trials
    rho = balanced_rows(rng, n, scene.n_chirps)
    for lat in (1e-7, 5e-6):
        for r in (0.3, 1.0, 3.0):
            att = make_attacker("reactive", scene, rarms=r, latency_s=lat)
            cyc = simulate_cycles(scene, rho, rng, attacker=att, rng_attack=rng)
            kd = int(detect(cyc.frames, rho, scene.sigma_n).alarm.sum())
            kl = int(opt_in.spill_test(cyc.frames, rho, scene.sigma_n, first, pf=1e-6).alarm.sum())
            out.append({"rarms": r, "latency_s": lat, "c15": kd, "spill": kl, "trials": n})
            rows.append(f"| {r:g} | {lat * 1e6:g} us | {rate(kd, n)} | {rate(kl, n)} |")
    data["reactive"] = {"first_sample": first, "rows": out}

    n_ramp = 2000
    att = make_attacker("ramp", scene, rarms_start=0.0, rarms_end=2.0, n_ramp_cycles=n_ramp)
    rho = balanced_rows(rng, n_ramp, scene.n_chirps)
    cyc = simulate_cycles(scene, rho, rng, attacker=att, rng_attack=rng)
    det = detect(cyc.frames, rho, scene.sigma_n)
    z = opt_in.silent_power_z(det.rms, rho, scene.sigma_n, scene.n_samples)
    h = opt_in.cusum_threshold(1e6, 0.5)
    _, alarm = opt_in.cusum_silent_power(z, k=0.5, h=h)
    first_c = int(np.argmax(det.alarm)) if det.alarm.any() else None
    first_s = int(np.argmax(alarm)) if alarm.any() else None
    ramp_r = lambda c: None if c is None else 2.0 * c / n_ramp    # noqa: E731
    data["ramp"] = {"first_alarm_c15": first_c, "first_alarm_cusum": first_s, "h": h}
    rows += ["", f"**CUSUM across cycles** against a ramp from RARMS 0 to 2 over {n_ramp} cycles (sigma_n fixed by "
             f"calibration): score z = standardised mean silent-chirp power (exactly N(0,1)-scaled under noise), "
             f"allowance k = 0.5, h = {h:.2f} for an in-control average run length of 1e6 cycles (Siegmund). "
             f"First alarm of C(1.5): cycle {first_c} (RARMS {ramp_r(first_c) or float('nan'):.3f}); "
             f"first CUSUM alarm: cycle {first_s} (RARMS {ramp_r(first_s) or float('nan'):.3f}).", ""]
    return rows


def calibration_risk(data: dict) -> list[str]:
    scene = radar_scene("table1")
    dof = scene.n_samples
    rows = ["| attacker present during calibration (RARMS) | sigma_n estimate / true | PM(1.5) of a later random "
            "attack at RARMS 1 | at RARMS 2 | at RARMS 3 |", "|---:|---:|---:|---:|---:|"]
    out = []
    for r_cal in (0.0, 0.5, 1.0, 2.0):
        infl = np.sqrt(1 + r_cal ** 2)
        pms = []
        for r in (1.0, 2.0, 3.0):
            # detector uses sigma_hat = infl * sigma: D0 = rms / sigma_hat -> same as eta scaled by infl
            pm = float(pf_pm_closed_form(PAPER_ETA * infl, n_chirps=scene.n_chirps, dof=dof, snr=1.0,
                                         rarms=r)["p_quiet"])
            pms.append(pm)
        out.append({"rarms_during_calibration": r_cal, "inflation": infl, "pm": pms})
        rows.append(f"| {r_cal:g} | {infl:.3f} | " + " | ".join(f"{p:.3g}" for p in pms) + " |")
    data["calibration"] = out
    return rows


ATTACKER_NOTES = """What the RMS detector cannot see, plainly:

- **reactive** repeaters answer only the chirps the victim actually transmits, with the same replica on each: the
  silent chirps stay clean (D0 quiet) and every active chirp rises alike (D1 compares each active chirp with their
  mean, so it is quiet too). Invisible at any RARMS. The spill test below catches it only when its delay
  (distance plus latency) exceeds the longest round trip the receiver passes; a nearer, faster one is physically a
  target at range d + c L / 2 that answers the active chirps only, and nothing in the samples tells it apart.
- **lfsr_predictor** against an LFSR activation source learns the register from the on-air pattern
  (Berlekamp-Massey) and attacks only the chirps it predicts active: invisible, exactly as the paper warns. Against
  uniformly random sequences (the law of the firmware's secure source, `os.urandom`; seeded here so that the table
  reproduces) its guesses are coin flips, it hits silent chirps, and D0 catches it.
- **ghost** transmits in every chirp period, so it lands on silent chirps too: D0 sees it once its raw RMS is large
  (RARMS above ~1.1), but a weak ghost stays under D0 while still planting a strong target after the range FFT
  (next section).
- **ramp** is missed while its RARMS is low and caught once it passes ~1.1; the CUSUM below catches it much earlier.
- **D1 has a blind side**: an active chirp below the mean gives D1 <= Rbar / (Rbar + sigma_n) < 1, so at any
  eta >= 1 only an active chirp *above* the mean can alarm. An attack spread evenly over the active chirps (the
  reactive repeater, or `lfsr_predictor` once it knows rho) raises Rbar with them and leaves D1 quiet at any RARMS:
  the 'alarms from D1' column stays 0 for every attacker. Only D0, on the silent chirps, and therefore only the
  secrecy of rho, stands against such attacks.
"""

NUISANCE_NOTES = """Reading the table: a fluctuating target does not change the silent chirps, so D0 is unaffected;
D1 compares active chirps with their mean, so a target whose power changes from chirp to chirp (Swerling 2) at high
SNR raises D1 false alarms, while a per-cycle fluctuation (Swerling 1) scales all active chirps alike and D1 stays
quiet. A drift of the true noise above the calibrated sigma_n multiplies every silent D0 by the drift factor: PF
explodes once the factor passes the threshold's margin over 1 + a few / sqrt(2 N_s) (eta_CFAR = 1.118 for
Table I, so a 20 % drift already alarms every cycle at eta_CFAR, but not at 1.5). Noise *below* calibration only
costs sensitivity. ADC clipping lowers the RMS of the chirps it hits, so it removes energy rather than adding it;
on its own it does not raise false alarms in these runs."""

GHOST_RARMS = (0.01, 0.03, 0.05, 0.1, 0.15, 0.2, 0.3, 0.5, 0.7, 1.0, 1.1)

GHOST_NOTES = """The RMS detector judges a chirp by its total energy; a coherent attacker packs the same energy into
one range bin, where the range FFT adds N_s samples coherently (a gain of N_s / 2 for a real sinusoid, 27 dB for
Table I). A ghost whose raw RMS is only ~1 dB above the noise (RARMS 0.5) thus stands 20 dB or more above the noise
floor after the FFT, with no alarm from C(1.5), and a target detector downstream reports it as a car at 25 m;
once the ghost is as strong as the real echo (RARMS ~ 1 at 0 dB SNR), a single-target estimator that takes the
strongest peak jumps to the ghost in a good share of the cycles (an 18 m range error) while C(1.5) still mostly
stays silent.
The spectral silent-chirp test (`carav_stream.detect.opt_in.spectral_silent_test`) looks at the silent chirps'
range spectra, where no echo may be, with an exact threshold for PF = 1e-6 (bins of white Gaussian noise are
exponential and independent). The integrated test (`integrated_silent_test`) sums each bin's power over the
silent chirps first: the ghost's power adds M times, the noise's spread only sqrt(M) times, and the sum of M
exponentials (a Gamma(M, 1) law) keeps the threshold exact. The coherent test (`coherent_silent_test`) builds the
radar's own range-Doppler map from the silent chirps instead of the active ones, so a ghost that transmits in every
chirp period integrates there as it does in the map the radar reports targets from. The question that matters is
the last two columns: a ghost the radar would report (its CFAR lists a target at the ghost's range) without an
alarm from any test is a ghost that reaches the car's decisions unnoticed; the line under the table counts them.
With 32 silent chirps of 1080 samples, the non-coherent sum is as sensitive as the coherent map here (its
threshold is lower because it searches fewer cells); the coherent map's advantage grows with the number of
chirps and at lower SNR per chirp."""


def ghost_notes(rows: list[dict], n: int) -> str:
    """Where each test starts catching every ghost of the table (computed from the rows)."""
    def first_all(key):
        return next((r["rarms"] for r in rows if r[key] == n), None)

    parts = []
    for key, name in (("alarms", "C(1.5)"), ("spectral_detections", "the single-chirp spectral test"),
                      ("integrated_detections", "the integrated spectral test"),
                      ("coherent_detections", "the coherent silent-chirp test"),
                      ("reported_by_radar", "the radar's own target detection (it reports the ghost)")):
        r = first_all(key)
        parts.append(f"{name} from RARMS {r:g}" if r is not None else f"{name} at no RARMS of the table")
    unseen = [(r["rarms"], r["reported_unseen"]) for r in rows if r["reported_unseen"]]
    gap = ("; cycles where the radar reports the ghost and no test alarms: " +
           ", ".join(f"{k}/{n} at RARMS {r:g}" for r, k in unseen)) if unseen else (
        "; in no cycle of the table does the radar report the ghost without an alarm from some test")
    return "Every cycle of a row is caught by " + ", by ".join(parts) + gap + "."


CALIBRATION_NOTES = """`estimate_sigma_n` averages the power of the silent chirps of attack-free calibration
cycles. An attacker present during calibration inflates the estimate to sqrt(1 + RARMS^2) sigma_n, which scales
every D0 down by the same factor: the detector then misses that attacker and anything weaker. Closed form (Table I,
random attack), PM at eta = 1.5 after calibrating under an attack of the given RARMS:"""
