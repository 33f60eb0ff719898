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
    "std_msgs/msg/String": """
string data
""",
    "geometry_msgs/msg/QuaternionStamped": """
std_msgs/Header header
Quaternion quaternion
""",
    "geometry_msgs/msg/TwistStamped": """
std_msgs/Header header
Twist twist
""",
    "geometry_msgs/msg/Wrench": """
Vector3  force
Vector3  torque
""",
    "geometry_msgs/msg/WrenchStamped": """
std_msgs/Header header
Wrench wrench
""",
    "geometry_msgs/msg/PoseWithCovariance": """
Pose pose
float64[36] covariance
""",
    "geometry_msgs/msg/PoseWithCovarianceStamped": """
std_msgs/Header header
PoseWithCovariance pose
""",
    "geometry_msgs/msg/VelocityStamped": """
std_msgs/Header header
string body_frame_id
string reference_frame_id
Twist velocity
""",
    "tf2_msgs/msg/TF2Error": """
uint8 NO_ERROR = 0
uint8 LOOKUP_ERROR = 1
uint8 CONNECTIVITY_ERROR = 2
uint8 EXTRAPOLATION_ERROR = 3
uint8 INVALID_ARGUMENT_ERROR = 4
uint8 TIMEOUT_ERROR = 5
uint8 TRANSFORM_ERROR = 6

uint8 error
string error_string
""",
    "service_msgs/msg/ServiceEventInfo": """
uint8 REQUEST_SENT = 0
uint8 REQUEST_RECEIVED = 1
uint8 RESPONSE_SENT = 2
uint8 RESPONSE_RECEIVED = 3
uint8 event_type
builtin_interfaces/Time stamp
char[16] client_gid
int64 sequence_number
""",
    "rcl_interfaces/msg/ParameterValue": """
uint8 type
bool bool_value
int64 integer_value
float64 double_value
string string_value
byte[] byte_array_value
bool[] bool_array_value
int64[] integer_array_value
float64[] double_array_value
string[] string_array_value
""",
    "rcl_interfaces/msg/Parameter": """
string name
ParameterValue value
""",
    "rcl_interfaces/msg/FloatingPointRange": """
float64 from_value
float64 to_value
float64 step
""",
    "rcl_interfaces/msg/IntegerRange": """
int64 from_value
int64 to_value
uint64 step
""",
    "rcl_interfaces/msg/ParameterDescriptor": """
string name
uint8 type
string description
string additional_constraints
bool read_only false
bool dynamic_typing false
FloatingPointRange[<=1] floating_point_range
IntegerRange[<=1] integer_range
""",
    "rcl_interfaces/msg/SetParametersResult": """
bool successful
string reason
""",
    "rcl_interfaces/msg/ListParametersResult": """
string[] names
string[] prefixes
""",
}

#: Services (.srv text: request, ``---``, response), as ROS 2 Jazzy ships them. Each one also gets the
#: ``<Name>_Event`` message and the service's own description (request_message, response_message,
#: event_message) that rosidl hashes: see zentf/ros/types.py.
SERVICES: dict[str, str] = {
    "std_srvs/srv/Empty": """
---
""",
    "std_srvs/srv/Trigger": """
---
bool success   # indicate successful run of triggered service
string message # informational, e.g. for error messages
""",
    "std_srvs/srv/SetBool": """
bool data # e.g. for hardware enabling / disabling
---
bool success   # indicate successful run of triggered service
string message # informational, e.g. for error messages
""",
    "turtlesim/srv/Spawn": """
float32 x
float32 y
float32 theta
string name # Optional.  A unique name will be created and returned if this is empty
---
string name
""",
    "turtlesim/srv/Kill": """
string name
---
""",
    "turtlesim/srv/TeleportAbsolute": """
float32 x
float32 y
float32 theta
---
""",
    "rcl_interfaces/srv/GetParameters": """
string[] names
---
ParameterValue[] values
""",
    "rcl_interfaces/srv/SetParameters": """
Parameter[] parameters
---
SetParametersResult[] results
""",
    "rcl_interfaces/srv/SetParametersAtomically": """
Parameter[] parameters
---
SetParametersResult result
""",
    "rcl_interfaces/srv/ListParameters": """
uint64 DEPTH_RECURSIVE=0
string[] prefixes
uint64 depth
---
ListParametersResult result
""",
    "rcl_interfaces/srv/DescribeParameters": """
string[] names
---
ParameterDescriptor[] descriptors
""",
    "rcl_interfaces/srv/GetParameterTypes": """
string[] names
---
uint8[] types
""",
    # tf2_ros runs LookupTransform as an action; zentf serves it as one request (the goal) and one
    # reply (the result), so under --wire ros2 it is a service of this shape between zentf's own
    # BufferServer and BufferClient (ROS 2's action clients use other keys and do not reach it)
    "tf2_msgs/action/LookupTransform": """
string target_frame
string source_frame
builtin_interfaces/Time source_time
builtin_interfaces/Duration timeout
builtin_interfaces/Time target_time
string fixed_frame
bool advanced
---
geometry_msgs/TransformStamped transform
tf2_msgs/TF2Error error
""",
    "tf2_msgs/srv/FrameGraph": """
---
string frame_yaml
""",
}
