"""MotionKit's core without Blender: loading the native module, rotation channels (and the IK's
swing-twist coordinates), resample plans, bone mapping (names, shapes, schemes, map files) and its
presets, foot contacts and root motion, and the worker thread beside Blender's. Nothing here imports bpy
(a test checks), so all of it runs in plain Python."""
