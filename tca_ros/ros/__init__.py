"""The ROS 2 layer: the simulator node and the PID controller node.

tca_node (ros/node.py) with its rclpy-free core and episode, tca_pid (ros/pid_node.py).
"""
