"""ROS 2 message formats, pure (no Zenoh): .msg definitions, CDR codec, DDS type names, RIHS01 hashes.

    >>> from zentf.ros import encode, decode, type_hash, dds_type_name
    >>> type_hash("tf2_msgs/msg/TFMessage")[:14]
    'RIHS01_e369d0f'

Modules: ``definitions`` (the .msg text of zentf's types), ``msgdef`` (parser), ``typehash`` (REP-2011
hashes), ``cdr`` (generic XCDR1 codec), ``tf`` (fast TFMessage path), ``codec`` (zentf messages <-> CDR),
``types`` (registry, names, hashes), ``errors``.
"""
from __future__ import annotations

from .cdr import ENCAPSULATION_LE, deserialize, serialize
from .codec import decode, decode_plain, encode, is_known
from .errors import CdrError, DefinitionError, RosFormatError, UnknownTypeError
from .msgdef import Field, MsgDef, parse_msg, parse_schema
from .tf import encode_tf, tf_samples
from .typehash import type_description
from .types import (dds_type_name, definition, definition_text, known_types, message_types, register_definition,
                    register_service_definition, ros_type_name, schema_text, service_types, type_hash)

__all__ = [
    "ENCAPSULATION_LE", "deserialize", "serialize", "decode", "decode_plain", "encode", "is_known",
    "CdrError", "DefinitionError", "RosFormatError", "UnknownTypeError", "Field", "MsgDef", "parse_msg",
    "parse_schema", "encode_tf", "tf_samples", "type_description", "dds_type_name", "definition",
    "known_types", "register_definition", "register_service_definition", "ros_type_name", "schema_text",
    "service_types", "type_hash", "definition_text", "message_types",
]
