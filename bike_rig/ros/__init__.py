"""The ROS boundary: every module that imports rclpy, a ``bike_rig_msgs`` class or the Foxglove SDK.

The nodes (:mod:`.nodes`), the launcher, the graph watch, the ROS environment and QoS helpers,
the demo and the republisher. Everything outside this package imports without a ROS runtime.
"""
