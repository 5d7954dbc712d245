"""MuJoCo physics: model composition, the simulator, run logs, perturbations and metrics."""
