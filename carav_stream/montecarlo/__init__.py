"""Monte Carlo of the detector: cycle sources (the paper's model and the radar chain) and their exact fast paths,
PF(eta) and PM(eta) sweeps with Clopper-Pearson intervals.

paper_model   the paper's R = n + rho x + a model: full samples, or exact per-chirp energies (sufficient statistics)
radar_source  the radar signal chain (carav_stream.radar) as a cycle source, any attacker model
array_source  the paper's model on a receiver array: independent noise per receiver, one attacker steered over them
engine        simulate_q, curves_from_q, sweep: Q per cycle once, then every eta of a grid
study_file    `carav study`'s study file, checked whole; study: its points, seeds and tasks on Dask distributed
"""
