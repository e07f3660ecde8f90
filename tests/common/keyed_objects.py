"""Objects with keys for the Blender tests (needs bpy): an empty whose location is keyed."""
import bpy


def animated_empty(animdata, frames, location, name="Mover"):
    """An empty with one key per frame on each location channel (location: (3, frames)), and its action."""
    obj = bpy.data.objects.new(name, None)
    bpy.context.scene.collection.objects.link(obj)
    action = animdata.new_action(f"{name}Action")
    animdata.assign(obj, action)
    animdata.write_keys(obj, action, [("location", k, "Object Transforms") for k in range(3)], frames, location)
    return obj, action
