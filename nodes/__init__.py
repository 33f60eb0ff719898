"""Demo node programs, each runnable alone as `python -m nodes.<name>`.

Thin users of the zentf library, the same demos people learn TF with:
`static_transform_publisher`; the drones `frames_publisher` and `plots_publisher`; the laser and
camera `point_publisher`, `frame_listener` and `point_listener`; the turtles `turtlesim`,
`turtle_tf_broadcaster`, `turtle_follower`, `turtle_teleop` and `turtle_teleop_key`; tf2_ros's
`buffer_server`; the robot model's `robot_state_publisher` and `joint_state_publisher`. Every program takes
the shared node
options of `zentf.options` (flags or ZENTF_* environment variables).
"""

NODE_PROGRAMS = (
    "static_transform_publisher", "frames_publisher", "plots_publisher", "point_publisher",
    "frame_listener", "point_listener", "turtlesim", "turtle_tf_broadcaster", "turtle_follower",
    "turtle_teleop", "turtle_teleop_key", "buffer_server", "robot_state_publisher", "joint_state_publisher",
)
