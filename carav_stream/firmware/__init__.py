"""What composes the kernels into the radar's firmware: Algorithm 1 in one process, the target list with its CFAR
detection, and the detection thresholds designed for a scene in closed form."""
