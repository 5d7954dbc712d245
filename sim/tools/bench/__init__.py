"""Benchmarks behind ``nhsim bench`` (see sim/cli/bench.py)."""
