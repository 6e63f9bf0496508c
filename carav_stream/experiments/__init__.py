"""The paper's reproduction and the experiments beyond it, built on the kernels, the firmware and the Monte Carlo.

beyond_paper       the tables beyond the paper that `carav reproduce` adds (every attacker, nuisances, ghosts, ...)
doc_outputs        command outputs quoted in the documents, regenerated and checked (`carav reproduce --check`)
secondary_antenna  `carav experiment secondary-antenna`: the paper's Figures 6-8
matlab_table1, interference, cfar_experiment, clutter, latency, near_echoes, blind_zones, fidelities
                   the other `carav experiment` studies
reporting          small helpers shared by the above
"""
