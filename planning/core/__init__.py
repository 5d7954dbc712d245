"""Core types of the planning layer: poses and geometry, worlds, maps, robot specs, kinematics."""
