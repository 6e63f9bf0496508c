"""Recorded and streamed samples: SigMF recordings of the ADC's codes, TI DCA1000 raw captures and their live UDP
stream, GNU Radio's ZeroMQ streams (gr-zeromq messages, PMT tags, cycles framed from items), and the private
activation log that goes beside them (the activation sequence is firmware state: never in the samples or their
metadata)."""
