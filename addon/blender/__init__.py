"""The only code that reads or writes Blender data in bulk: actions and their keys in every Blender's
world (animdata), and armatures' pose channels and rigs (pose_channels)."""
