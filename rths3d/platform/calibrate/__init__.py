"""Calibrating and identifying the platform, apart from simulating it: the kinematic
calibration of its 42 parameters (:mod:`.kinematic`) with its pose tables and pose design
(:mod:`.poses`), the force-torque sensor's calibration and payload identification
(:mod:`.fts`), and the heave transfer function identified from multisine runs (:mod:`.heave`).
The old module names (``rths3d.platform.calibration``, ``fts_calibration``, ``pose_design``,
``identify``) still import, with a DeprecationWarning."""
