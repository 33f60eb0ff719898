"""The runnable programs by name (``zentf run NAME``, launch files' ``run: NAME``): module and one line each.

Only names and module paths live here, so listing them imports nothing; each module has ``main(argv)``
and runs as ``python -m <module>``.
"""
from __future__ import annotations

__all__ = ["PROGRAMS", "module_of"]

#: name -> (module, one-line description); demos first as `zentf run --list` shows them
PROGRAMS: dict[str, tuple[str, str]] = {
    "static_transform_publisher": ("zentf.tools.static_transform_publisher",
                                   "publish one latched transform (tf2_ros static_transform_publisher)"),
    "robot_state_publisher": ("zentf.tools.robot_state_publisher",
                              "a URDF's frames on tf_static and, from joint_states, on tf"),
    "joint_state_publisher": ("zentf.tools.joint_state_publisher",
                              "joint_states for a URDF's movable joints: values, --sweep, --gui sliders"),
    "buffer_server": ("zentf.tools.buffer_server", "tf2_ros's buffer server: answers BufferClients' lookups"),
    "dds_bridge": ("zentf.tools.dds.program", "relay tf and more between a DDS ROS 2 domain and this graph"),
    "turtlesim": ("zentf.demos.turtlesim", "headless turtlesim: turtles, their poses and ROS's services"),
    "turtle_tf_broadcaster": ("zentf.demos.turtle_tf_broadcaster", "world -> <turtlename> from a turtle's pose"),
    "turtle_follower": ("zentf.demos.turtle_follower", "spawn turtle2 and steer it toward turtle1 through tf"),
    "turtle_teleop": ("zentf.demos.turtle_teleop", "drive a turtle along a scripted pattern"),
    "turtle_teleop_key": ("zentf.demos.turtle_teleop_key", "drive a turtle with this terminal's arrow keys"),
    "frames_publisher": ("zentf.demos.frames_publisher", "two drones, av1 and av2, flying in world"),
    "plots_publisher": ("zentf.demos.plots_publisher", "the drones' trails as line-strip markers"),
    "point_publisher": ("zentf.demos.point_publisher", "an obstacle seen by the laser, on laser_point"),
    "point_listener": ("zentf.demos.point_listener", "each obstacle point in base_link, through a MessageFilter"),
    "frame_listener": ("zentf.demos.frame_listener", "every second, where the laser is as seen from the camera"),
}


def module_of(name: str) -> str:
    """The module of program ``name``; KeyError lists the known names."""
    try:
        return PROGRAMS[name][0]
    except KeyError:
        raise KeyError(f"no program named {name!r} (zentf run --list shows {len(PROGRAMS)}: "
                       f"{', '.join(sorted(PROGRAMS))})") from None
