"""Tests of the live ROS 2 node."""
