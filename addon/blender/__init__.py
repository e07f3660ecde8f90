"""The only code that reads or writes Blender data in bulk (foreach_get, foreach_set, key arrays; a test
checks): actions, their keys and frame rates in every Blender's world (animdata), armatures' hierarchy,
rest poses, pose channels and native rigs (pose_channels), and motion files through Blender's importers,
taken back whole on failure (imports)."""
