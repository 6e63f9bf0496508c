"""Target processing (Algorithm 1, step 6): range and velocity estimators, CRLB, reference chains."""
from carav_stream.estimate.estimators import DEFAULT_METHOD, METHODS, Estimates, estimate
from carav_stream.estimate.geometry import Geometry

__all__ = ["DEFAULT_METHOD", "METHODS", "Estimates", "Geometry", "estimate"]
