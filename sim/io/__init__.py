"""Runs written in formats other tools read: ROS 2 bags (:mod:`sim.io.bag`)."""
