"""Procedures on a turntable: acquisition, acceptance, their figures, the demo run."""
