"""Tools for the controller developer, built on the physics layer (tca_ros.model).

- linearize: the small-signal plant at an operating point (python-control);
- envs: a gymnasium tracking environment over the simulator (``TcaTracking-v0``);
- batch: N muscles stepped at once with NumPy.

Nothing here imports rclpy; matplotlib only in plots.py.
"""
