"""CARAV cyberattack detection (paper Section V): pure kernels on numpy arrays, vectorised over cycles.

detector    chirp_rms, adc_chirp_rms, detect, detect_from_rms, estimate_sigma_n: D0, D1, D, Q and C(eta)
            (receivers=True: a receiver array's frames, one RMS per chirp over all receivers)
receivers   per-receiver diagnostics of an array, the steering's gains, the law of the combined statistic
stats       Clopper-Pearson intervals, closed-form PF/PM, CFAR threshold, importance sampling
thresholds  minimax, CFAR and min PF + PM designs from PF/PM curves
opt_in      opt-in detectors beyond the paper: silent-chirp tests, spill test, CUSUM across cycles
"""
