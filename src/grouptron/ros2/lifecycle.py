"""The node as a ROS 2 lifecycle node (``grouptron ros2 --lifecycle``): configure loads the
model and makes the topics, activate starts forecasting and publishing, deactivate stops both
(an inactive node publishes nothing), cleanup frees the model and topics; driven through the
``lifecycle_msgs`` services ``<node>/change_state`` and ``<node>/get_state``."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from grouptron.errors import GrouptronError
from grouptron.inference.learning import LearningOptions
from grouptron.inference.predictor import Predictor
from grouptron.ros2.node import NodeOptions, NodeParts, loaded


def lifecycle_node(
    predictor: Predictor | Callable[[], Predictor],
    options: NodeOptions,
    *,
    online: bool,
    learn: LearningOptions | None,
) -> Any:
    """The node as a lifecycle node (``make_node``)."""
    from rclpy.lifecycle import LifecycleNode, State, TransitionCallbackReturn

    class ForecastLifecycleNode(NodeParts, LifecycleNode):
        """See the module: a lifecycle node that forecasts while active."""

        def __init__(self) -> None:
            LifecycleNode.__init__(self, options.name)
            self.configured = False

        def on_configure(self, state: State) -> TransitionCallbackReturn:
            try:
                self.setup(loaded(predictor), options, online, learn)
            except GrouptronError as error:
                self.get_logger().error(f"configure failed: {error}")
                return TransitionCallbackReturn.FAILURE
            self.active = False
            self.configured = True
            return TransitionCallbackReturn.SUCCESS

        def on_activate(self, state: State) -> TransitionCallbackReturn:
            self.active = True
            return TransitionCallbackReturn.SUCCESS

        def on_deactivate(self, state: State) -> TransitionCallbackReturn:
            self.active = False
            self.latest = self.waiting = None
            return TransitionCallbackReturn.SUCCESS

        def on_cleanup(self, state: State) -> TransitionCallbackReturn:
            self._free()
            return TransitionCallbackReturn.SUCCESS

        def on_shutdown(self, state: State) -> TransitionCallbackReturn:
            self._free()
            return TransitionCallbackReturn.SUCCESS

        def stop(self) -> None:
            if self.configured:
                super().stop()

        def _free(self) -> None:
            """The state kept, then the topics, timers, session and model let go."""
            if self.configured:
                self._keep_state(final=True)
                self.teardown()
                self.configured = False
                del self.session, self.live, self.predictor

    return ForecastLifecycleNode()
