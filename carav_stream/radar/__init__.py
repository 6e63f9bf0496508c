"""The radar signal chain, as pure functions on numpy arrays vectorised over cycles.

scene, scene_loader   the scene (radar, targets, attackers) and its files and presets
physics               dechirped echoes in beat and waveform fidelity
noise, activation     fast Gaussian samples; activation sequences (secure, seeded, LFSR)
attackers             attack models a_k[m]: what each puts on the air, seeing only the on-air emission
synth                 transmit -> channel -> attacker -> ADC, cycle-batched
adc                   quantisation, codes and the ADC step
streams               the scene, seed and random streams a run's blocks share
"""
