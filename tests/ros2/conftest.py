"""The ROS 2 tests' graph: rclpy on a domain of its own, on this machine only."""

from __future__ import annotations

import os
import random
from collections.abc import Iterator

import pytest


@pytest.fixture(scope="module")
def graph() -> Iterator[None]:
    """rclpy on a domain of its own, on this machine only."""
    rclpy = pytest.importorskip("rclpy")
    os.environ["ROS_DOMAIN_ID"] = str(random.randint(10, 99))
    os.environ["ROS_LOCALHOST_ONLY"] = "1"
    rclpy.init()
    yield
    rclpy.try_shutdown()
