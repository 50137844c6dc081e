"""ROS-free, typed science core of bike_rig: one paper equation, one function."""
