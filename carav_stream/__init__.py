"""carav-stream: streaming FMCW radar simulation with in-line CARAV cyberattack detection."""
__version__ = "0.1.0"
