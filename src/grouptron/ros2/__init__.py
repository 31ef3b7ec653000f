"""A live ROS 2 node (``grouptron ros2``): tracked people in, forecasts, markers and
diagnostics out, on every message (needs the ``ros2`` extra: rclpy and the message packages).
``messages`` converts between messages and arrays, ``node`` is the node, ``replay`` publishes
a bag's people on a live graph."""
