"""Planning layer of nhsim: geometry, worlds, kinematics, planners and trajectories.

Pure numerics; nothing here imports MuJoCo or the control layer.
"""
