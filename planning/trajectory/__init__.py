"""Reference trajectories: the Trajectory type, analytic references, smoothing, speed profile, plan to trajectory."""
