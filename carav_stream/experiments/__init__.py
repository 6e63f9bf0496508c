"""The paper's reproduction and the experiments beyond it, built on the kernels, the firmware and the Monte Carlo.
Engines only: each takes plain arguments, returns its numbers and hears of progress through callbacks; the commands
that parse options and print (`carav reproduce`, `carav experiment NAME`) live in carav_stream/cli/.

reproduction       `carav reproduce`: the paper's figures and claims beside ours, as markdown
beyond_paper       the tables beyond the paper that `carav reproduce` adds (every attacker, nuisances, ghosts, ...)
doc_outputs        command outputs quoted in the documents, regenerated and checked (`carav reproduce --check`)
secondary_antenna  `carav experiment secondary-antenna`: the paper's Figures 6-8
matlab_table1, interference, cfar_experiment, clutter, latency, near_echoes, blind_zones, fidelities, tracks,
receivers          the other `carav experiment` studies
reporting          small helpers shared by the above, and the settings of a reproduction
errors             ExperimentError: a setting refused, or a quoted command that failed
"""
