"""The demos people learn TF with, as programs (``zentf run NAME``): the laser and camera
(point_publisher, point_listener, frame_listener), the drones (frames_publisher, plots_publisher) and the
turtles (turtlesim, turtle_tf_broadcaster, turtle_follower, turtle_teleop, turtle_teleop_key)."""
