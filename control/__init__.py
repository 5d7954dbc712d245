"""Control layer of nhsim: trackers, drive mappings and gain sets.

Pure numerics; knows trajectories and kinematics (``planning``), never MuJoCo.
"""
