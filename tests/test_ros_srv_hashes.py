"""RIHS01 hashes of service types (REP-2011, rosidl_generator_type_description) against published values.

The expected hashes are ROS 2 Jazzy's own, from the type description JSON it installs
(/opt/ros/jazzy/share/<pkg>/srv/<Srv>.json) as published in public sources: rmw_zenoh's docs/design.md
(example_interfaces/srv/AddTwoInts in its service key example) and tables of Jazzy's hashes
(ruby-asterism/asterism tools/ros2_jazzy/type_hashes.txt; a public C++ header listing the std_srvs and
rcl_interfaces service hashes). zentf computes every hash from the .srv text; none is pasted in zentf.
"""
from __future__ import annotations

import pytest

from zentf.ros import DefinitionError, UnknownTypeError, dds_type_name, type_hash
from zentf.ros.types import definition, register_service_definition, service_types, split_srv

JAZZY = {
    "std_srvs/srv/Trigger": "RIHS01_eeff2cd6fa5ad9d27cdf4dec64818317839b62f212a91e6b5304b634b2062c5f",
    "std_srvs/srv/SetBool": "RIHS01_abe9e4bb6b41b40e6789712c00ec8871923e089af3f667a79992a428cff2da0a",
    "std_srvs/srv/Empty": "RIHS01_5888399dedec5ccc85ea6451949fd2c9f97bfdf963f9a588821639fcd31b5d19",
    "rcl_interfaces/srv/ListParameters": "RIHS01_3e6062bfbb27bfb8730d4cef2558221f51a11646d78e7bb30a1e83afac3aad9d",
    "rcl_interfaces/srv/GetParameters": "RIHS01_bf9803d5c74cf989a5de3e0c2e99444599a627c7ff75f97b8c05b01003675cbc",
    "rcl_interfaces/srv/GetParameterTypes": "RIHS01_da199c878688b3e530bdfe3ca8f74cb9fa0c303101e980a9e8f260e25e1c80ca",
    "rcl_interfaces/srv/SetParameters": "RIHS01_56eed9a67e169f9cb6c1f987bc88f868c14a8fc9f743a263bc734c154015d7e0",
    "rcl_interfaces/srv/SetParametersAtomically":
        "RIHS01_0e192ef259c07fc3c07a13191d27002222e65e00ccec653ca05e856f79285fcd",
    "rcl_interfaces/srv/DescribeParameters":
        "RIHS01_845b484d71eb0673dae682f2e3ba3c4851a65a3dcfb97bddd82c5b57e91e4cff",
    "service_msgs/msg/ServiceEventInfo": "RIHS01_41bcbbe07a75c9b52bc96bfd5c24d7f0fc0a08c0cb7921b3373c5732345a6f45",
}


@pytest.mark.parametrize("name", sorted(JAZZY))
def test_service_hashes_match_ros2_jazzy(name):
    assert type_hash(name) == JAZZY[name]


def test_add_two_ints_as_in_rmw_zenoh_design_doc():
    register_service_definition("example_interfaces/srv/AddTwoInts", "int64 a\nint64 b\n---\nint64 sum\n")
    assert type_hash("example_interfaces/srv/AddTwoInts") == \
        "RIHS01_e118de6bf5eeb66a2491b5bda11202e7b68f198d6f67922cf30364858239c81a"
    assert type_hash("example_interfaces/srv/AddTwoInts_Event") == \
        "RIHS01_32c1d140259c71e5c355115942bcb31df98b4330e4d906b1b75ccb1c9b3ce6c8"
    assert type_hash("example_interfaces/srv/AddTwoInts_Request") == \
        "RIHS01_000c5fd92d6b2e1a05949348f584d6d652adea1e92d691792011ac2273508302"
    assert type_hash("example_interfaces/srv/AddTwoInts_Response") == \
        "RIHS01_de5c030d4af33cba2749310b249737b631594703f9300495f48bffb2b44dcc2f"
    assert dds_type_name("example_interfaces/srv/AddTwoInts") == "example_interfaces::srv::dds_::AddTwoInts_"


def test_every_zentf_service_type_has_a_definition_and_hash():
    from zentf.core.services import SERVICE_TYPES
    import zentf.core.parameters  # noqa: F401  (registers the rcl_interfaces services)

    known = set(service_types())
    for name in SERVICE_TYPES:  # tf2_msgs/action/LookupTransform too: zentf serves the action as a service
        assert name in known, name
        assert type_hash(name).startswith("RIHS01_")
        fields = [f.name for f in definition(name).fields]
        assert fields == ["request_message", "response_message", "event_message"]


def test_empty_parts_get_rosidl_dummy_member_and_bad_srv_is_refused():
    # std_srvs/Empty has empty parts: hashed with rosidl's dummy member (the Jazzy hash above checks it)
    assert definition("std_srvs/srv/Empty_Request").fields == ()
    assert split_srv("x/srv/Y", "int8 a\n---\n") == ("int8 a\n", "\n")
    with pytest.raises(DefinitionError, match="exactly one '---'"):
        register_service_definition("x/srv/NoSplit", "int8 a\n")
    with pytest.raises(DefinitionError, match="pkg/srv/Name"):
        register_service_definition("x/msg/Y", "---\n")
    with pytest.raises(UnknownTypeError, match="no definition"):
        type_hash("tf2_msgs/action/FollowPath")
