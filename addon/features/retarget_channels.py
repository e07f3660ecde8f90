"""The shape keys a retarget carries (RetargetOptions.channels; core/channel_carry.Carried, read by
blender/carried_reads) written into the target meshes' Keys' actions where the plan's options say (the
armature's own carried channels go with the bones' keys: retargeting._write)."""
from __future__ import annotations

import bpy

from ..blender import animdata
from ..core.channel_carry import Carried


def write_shapes(carried: Carried, frames, options, name: str, overwrite: bool, partial: bool) -> None:
    """The shape keys' values into each target Key's action as the armature's keys went into its own
    (options.into; overwrite; partial: a new action copies the Key's own, its other shapes' keys kept)."""
    for key, channels, values in carried.shapes:
        own = animdata.assigned_action(key)
        title = f"{name} ({key.user.name})"
        if overwrite and own is not None:
            animdata.write_keys(key, own, channels, frames, values)
        elif options.into == "current" and own is not None:
            animdata.merge_keys(key, own, channels, frames, values)
        elif options.into == "nla":
            action = animdata.new_action(title)
            try:
                animdata.write_keys(key, action, channels, frames, values)
                animdata.push_track(key, action, frames[0], options.blend, options.influence)
            except BaseException:
                bpy.data.actions.remove(action)
                raise
        else:
            action = animdata.copy_action(own, title) if partial and own is not None else \
                animdata.new_action(title)
            animdata.install_action(key, action, lambda keyed: animdata.write_keys(key, keyed, channels, frames,
                                                                                   values))
