"""Exact steering curves: Dubins and Reeds–Shepp words, compiled with numba."""
