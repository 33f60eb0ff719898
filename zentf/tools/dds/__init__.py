"""The DDS bridge (``zentf bridge dds``): a DDS ROS 2 domain <-> a zentf graph, through Cyclone DDS
(``pip install zentf[dds]``). ``bridge`` holds the relay, ``cyclone`` the DDS participant, ``idl`` the ROS
types as DDS types, ``convert`` the payload conversions."""
from __future__ import annotations

__all__ = ["DdsBridge", "DdsBridgeStats", "DEFAULT_TOPICS"]


def __getattr__(name: str):  # the bridge needs cyclonedds: imported when asked for
    if name in __all__:
        from . import bridge

        return getattr(bridge, name)
    raise AttributeError(name)
