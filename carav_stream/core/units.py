"""Physical constants and unit factors, defined once for the whole package."""
from __future__ import annotations

C_MPS = 299_792_458.0          # speed of light in vacuum [m/s]
K_BOLTZMANN = 1.380649e-23     # Boltzmann constant [J/K]
KMH = 1.0 / 3.6                # one km/h in m/s
