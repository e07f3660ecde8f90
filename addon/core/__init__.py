"""MotionKit's core without Blender: loading the native module, rotation channels, resample plans, bone
mapping (names, shapes, schemes, map files) and its presets, foot contacts and root motion. Nothing here
imports bpy (a test checks), so all of it runs in plain Python."""
