"""Benchmarks behind ``nhsim bench`` (see sim/commands/bench.py)."""
