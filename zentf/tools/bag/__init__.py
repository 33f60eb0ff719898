"""Bags: zentf's own MCAP recordings and ROS ones (ROS 1 .bag, rosbag2 .db3/.mcap), in and out.

One module per concern, as in rosbags: ``formats`` (what a path holds), ``mcapscan`` (tolerant
MCAP scanning), ``native`` (zentf MCAP writer/reader), ``ros`` and ``ros1scan`` (ROS bags through
rosbags), ``plain`` (ROS messages <-> zentf dicts), ``tfdecode`` (the /tf decoder), ``source``
(``open_bag``: one interface over all formats), ``info``, ``offline`` (``load_buffer``),
``convert``, ``mcapwrite`` (what the writers share), ``ros2write`` (zentf messages to
ROS 2 MCAP), ``ros2record`` (CDR samples of a ROS 2 graph to MCAP), ``playback`` (Recorder, Player over Zenoh),
``demo``. ROS formats need the optional ``rosbags`` package (``pip install 'zentf[ros]'``);
zentf's own bags do not.
"""
from __future__ import annotations

from .convert import convert
from .demo import write_drones_demo
from .errors import BagError, MissingDependencyError, UnknownFormatError
from .formats import BagFormat, detect_format
from .info import bag_info
from .native import (LATCHED_TOPICS, MESSAGE_ENCODING, PROFILE, BagMessage, BagReader, BagWriter, is_latched_key,
                     rebase_key)
from .offline import load_buffer, load_buffer_at
from .playback import Player, PlayStats, Recorder
from .ros2record import Ros2BagWriter
from .ros2write import Ros2Writer
from .source import Bag, open_bag, zentf_topic

__all__ = ["BagError", "UnknownFormatError", "MissingDependencyError", "BagFormat", "detect_format", "BagMessage",
           "BagWriter", "BagReader", "Recorder", "Player", "PlayStats", "bag_info", "rebase_key", "is_latched_key",
           "write_drones_demo", "PROFILE", "MESSAGE_ENCODING", "LATCHED_TOPICS", "Bag", "open_bag", "zentf_topic",
           "load_buffer", "load_buffer_at", "convert", "Ros2Writer", "Ros2BagWriter"]
