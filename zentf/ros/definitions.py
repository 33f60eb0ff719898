"""The ROS 2 interface definitions (.msg text) of every message type zentf has, as ROS 2 Jazzy ships them.

The text is the interface itself (field types and names, as documented for ROS 2); type hashes and
the CDR layout are derived from it, never pasted. Where zentf's dataclass has fewer fields than the ROS
type (visualization_msgs/Marker without the mesh/texture fields), the full ROS definition is kept here,
so the bytes and the hash match ROS 2; the codec fills the missing fields with defaults.
"""
from __future__ import annotations

__all__ = ["DEFINITIONS", "SERVICES"]

DEFINITIONS: dict[str, str] = {
    "builtin_interfaces/msg/Time": """
int32 sec
uint32 nanosec
""",
    "builtin_interfaces/msg/Duration": """
int32 sec
uint32 nanosec
""",
    "std_msgs/msg/Header": """
builtin_interfaces/Time stamp
string frame_id
""",
    "std_msgs/msg/ColorRGBA": """
float32 r
float32 g
float32 b
float32 a
""",
    "geometry_msgs/msg/Vector3": """
float64 x
float64 y
float64 z
""",
    "geometry_msgs/msg/Point": """
float64 x
float64 y
float64 z
""",
    "geometry_msgs/msg/Quaternion": """
float64 x 0
float64 y 0
float64 z 0
float64 w 1
""",
    "geometry_msgs/msg/Transform": """
Vector3 translation
Quaternion rotation
""",
    "geometry_msgs/msg/TransformStamped": """
std_msgs/Header header
string child_frame_id
Transform transform
""",
    "geometry_msgs/msg/PointStamped": """
std_msgs/Header header
Point point
""",
    "geometry_msgs/msg/Vector3Stamped": """
std_msgs/Header header
Vector3 vector
""",
    "geometry_msgs/msg/Pose": """
Point position
Quaternion orientation
""",
    "geometry_msgs/msg/PoseStamped": """
std_msgs/Header header
Pose pose
""",
    "geometry_msgs/msg/Twist": """
Vector3  linear
Vector3  angular
""",
    "tf2_msgs/msg/TFMessage": """
geometry_msgs/TransformStamped[] transforms
""",
    "rosgraph_msgs/msg/Clock": """
builtin_interfaces/Time clock
""",
    "turtlesim/msg/Pose": """
float32 x
float32 y
float32 theta

float32 linear_velocity
float32 angular_velocity
""",
    "sensor_msgs/msg/CompressedImage": """
std_msgs/Header header
string format
uint8[] data
""",
    "sensor_msgs/msg/JointState": """
std_msgs/Header header
string[] name
float64[] position
float64[] velocity
float64[] effort
""",
    "visualization_msgs/msg/UVCoordinate": """
float32 u
float32 v
""",
    "visualization_msgs/msg/MeshFile": """
string filename
uint8[] data
""",
    "visualization_msgs/msg/Marker": """
int32 ARROW=0
int32 CUBE=1
int32 SPHERE=2
int32 CYLINDER=3
int32 LINE_STRIP=4
int32 LINE_LIST=5
int32 CUBE_LIST=6
int32 SPHERE_LIST=7
int32 POINTS=8
int32 TEXT_VIEW_FACING=9
int32 MESH_RESOURCE=10
int32 TRIANGLE_LIST=11
int32 ARROW_STRIP=12
int32 ADD=0
int32 MODIFY=0
int32 DELETE=2
int32 DELETEALL=3
std_msgs/Header header
string ns
int32 id
int32 type
int32 action
geometry_msgs/Pose pose
geometry_msgs/Vector3 scale
std_msgs/ColorRGBA color
builtin_interfaces/Duration lifetime
bool frame_locked
geometry_msgs/Point[] points
std_msgs/ColorRGBA[] colors
string texture_resource
sensor_msgs/CompressedImage texture
UVCoordinate[] uv_coordinates
string text
string mesh_resource
MeshFile mesh_file
bool mesh_use_embedded_materials
""",
    "visualization_msgs/msg/MarkerArray": """
Marker[] markers
""",
}

#: Services: request and response parts (CDR only; their type hashes are not computed here).
SERVICES: dict[str, tuple[str, str]] = {
    "turtlesim/srv/Spawn": ("""
float32 x
float32 y
float32 theta
string name
""", """
string name
"""),
}
