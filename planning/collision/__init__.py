"""Collision checking: the exact footprint checker and its compiled grid front end."""
