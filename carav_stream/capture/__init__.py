"""Recorded samples: SigMF recordings of the ADC's codes, TI DCA1000 raw captures, and the private activation log
that goes beside either (the activation sequence is firmware state: never in the samples or their metadata)."""
