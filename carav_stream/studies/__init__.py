"""Studies built on the kernels and the Monte Carlo: the paper's reproduction, the experiments beyond it, and the
commands that run them.

sweep_command      `carav sweep`: PF/PM curves of one scene, thresholds, JSON and a plot
reproduce          `carav reproduce`: docs/REPRODUCTION.md (the paper's Figures 3-5 and its claims beside ours)
beyond_paper       the tables beyond the paper that `carav reproduce` adds (every attacker, nuisances, ghosts, ...)
secondary_antenna  `carav experiment secondary-antenna`: the paper's Figures 6-8
reporting          small helpers shared by the above
"""
