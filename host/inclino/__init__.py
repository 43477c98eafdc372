"""inclino: toolkit for magnetic borehole inclinometer probes."""
__version__ = "0.1.0"
