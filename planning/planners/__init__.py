"""Planners: the interface and registry, the sampling planners, sinusoidal steering, optimisation."""
