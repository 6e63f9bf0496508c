"""Target estimation of Algorithm 1, step 6: range and radial velocity from the active chirps of clean cycles.

Pipeline, vectorised over cycles (C cycles, M chirps, N fast-time samples):
1. Only the active chirps (rho True) are read, gathered into (C, A, N) (_common): every sum and fast-time FFT
   runs on them, and slow-time spectra scatter them back to their chirp times with zeros at the silent ones, the
   non-uniform DFT of the sparse active set.
2. Range-Doppler map |FFT_slow(FFT_fast(x))|^2 (_grid), its strongest cell; K targets (given, or estimated by
   MDL/AIC) found one by one, each removed from the data before the next search (RELAX-style).
3. Sub-bin frequencies at the cell and their refinement, by method: one file each in this package, named after
   the method, its docstring the method's mathematics; METHODS lists them in their declared order.
   The refining methods refine all targets of a cycle together, the others cancelled (_relax), each target's echo
   modelled from its round trip on and read from a few samples later (_onset).
4. Range with range-Doppler coupling removed: R = c/(2S) (f_b - 2 v / lambda), the range the beat measures
   (Geometry.range_seen); velocity from the chirp-to-chirp progression where the sums read it, the middle of the
   samples read (Geometry.doppler_scale_at)   (see geometry.py)

Inputs are scaled per cycle by their largest magnitude first, so amplitudes of 1e-30 and noise-free frames
(rank-deficient covariances) are handled; cycles without active chirps, with non-finite samples or with no
energy give NaN.

A new method is one new file here (_registry): a Method subclass (_method) that says how it locates and refines.
"""
from carav_stream.estimate.estimators._common import Chirps as _Chirps
from carav_stream.estimate.estimators._common import Estimates
from carav_stream.estimate.estimators._common import normalise as _normalise
from carav_stream.estimate.estimators._grid import search as _search
from carav_stream.estimate.estimators._method import Method
from carav_stream.estimate.estimators._pipeline import estimate, refine_at
from carav_stream.estimate.estimators._registry import DEFAULT_METHOD, METHODS, REGISTRY, method_named

# _Chirps, _normalise and _search: the kernels' tests reach the compaction and the map's search by these names
__all__ = ["DEFAULT_METHOD", "METHODS", "REGISTRY", "Estimates", "Method", "_Chirps", "_normalise", "_search",
           "estimate", "method_named", "refine_at"]
