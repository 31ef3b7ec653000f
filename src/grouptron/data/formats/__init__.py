"""Track files in: the formats (ETH/UCY rows, layouts of one's own, TrajNet++, ROS 2 bags), the
fields and checks they share, and what to tell a user whose file did not read."""
