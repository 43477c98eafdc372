"""Benchmarks (`inclino bench NAME --json`): each measures and states its targets."""
