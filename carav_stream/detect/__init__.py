"""CARAV cyberattack detection (paper Section V): kernels, statistics, Monte Carlo, threshold design, CLIs.

detector      chirp_rms, detect, detect_from_rms, estimate_sigma_n (pure kernels, vectorised over cycles)
stats         Clopper-Pearson intervals, closed-form PF/PM, CFAR threshold, importance sampling
thresholds    minimax, CFAR and min PF + PM designs from PF/PM curves
paper_model   the paper's R = n + rho x + a model: full samples or exact per-chirp energies
montecarlo    PF(eta), PM(eta) sweeps over cycle sources; radar_source: the radar signal chain as a source
extra         opt-in detectors: spectral silent-chirp test, latency test, CUSUM across cycles
sweep_cli     `carav sweep`;  reproduce: `carav reproduce` (docs/REPRODUCTION.md), with beyond.py (experiments
              beyond the paper) and reporting.py (shared helpers)
"""
