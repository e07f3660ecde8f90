"""The Retarget panel's settings, kept on the scene (scene.motionkit_retarget)."""
import bpy
from bpy.props import (BoolProperty, CollectionProperty, EnumProperty, FloatProperty, IntProperty,
                       PointerProperty, StringProperty)

from . import contact_props, retargeting


def _is_armature(self, obj):
    return obj.type == 'ARMATURE'


class MOTIONKIT_PG_bone_pair(bpy.types.PropertyGroup):
    source: StringProperty(name="Source", description="Bone of the source armature (or BVH joint)")
    target: StringProperty(name="Target", description="Bone of the target armature")


class MOTIONKIT_PG_retarget(bpy.types.PropertyGroup):
    source_kind: EnumProperty(name="Source", items=[
        ('ARMATURE', "Armature", "An animated armature in this file"),
        ('BVH', "BVH File", "A BVH file, imported as the source armature when retargeting")], default='ARMATURE')
    source: PointerProperty(name="Source Armature", type=bpy.types.Object, poll=_is_armature)
    bvh_path: StringProperty(name="BVH File", subtype='FILE_PATH')
    target: PointerProperty(name="Target Armature", type=bpy.types.Object, poll=_is_armature)
    pairs: CollectionProperty(type=MOTIONKIT_PG_bone_pair)
    active_pair: IntProperty(name="Active Pair")
    source_match: EnumProperty(name="Source Match Pose", items=retargeting.SOURCE_MATCHES, default='REST')
    match_frame: IntProperty(name="Match Frame", description="Frame of the source's match pose", default=0)
    target_match: EnumProperty(name="Target Match Pose", items=retargeting.TARGET_MATCHES, default='REST')
    root_motion: EnumProperty(name="Root Motion", items=retargeting.ROOT_MOTIONS, default="scaled")
    floor_root: EnumProperty(name="Floor Root", items=retargeting.FLOOR_ROOTS, default="auto",
                             description="What a target bone on the floor above the hips (a game rig's root) does")
    root_smoothing: FloatProperty(name="Smoothing", default=0.25, min=0.0, soft_max=2.0, unit='TIME_ABSOLUTE',
                                  description="Seconds of smoothing of the extracted root motion")
    plant_feet: BoolProperty(name="Plant Feet", default=True,
                             description="Feet that stand still in the source stay planted on the target "
                                         "(contacts detected on the source, held with full-body IK)")
    contacts: PointerProperty(type=contact_props.MOTIONKIT_PG_contacts)
    ground: BoolProperty(name="Feet on the Floor",
                         description="Move the root so that the target's lowest point touches the floor "
                                     "on the first frame")
    align_facing: BoolProperty(name="Align Facing", default=True,
                               description="Turn the motion by quarter turns so that each rig walks the way "
                                           "it faces")
    use_frame_range: BoolProperty(name="Frame Range", description="Retarget these source frames only")
    frame_start: IntProperty(name="Start", default=1)
    frame_end: IntProperty(name="End", default=250)
    overwrite: BoolProperty(name="Overwrite Target Action",
                            description="Write into the target's own action instead of a new one")

    def bone_map(self) -> list[tuple[str, str]]:
        return [(p.source, p.target) for p in self.pairs if p.source and p.target]

    def set_bone_map(self, pairs) -> None:
        self.pairs.clear()
        for source, target in pairs:
            item = self.pairs.add()
            item.source, item.target = source, target
        self.active_pair = 0


classes = contact_props.classes + (MOTIONKIT_PG_bone_pair, MOTIONKIT_PG_retarget)


def register_properties():
    bpy.types.Scene.motionkit_retarget = PointerProperty(type=MOTIONKIT_PG_retarget)


def unregister_properties():
    del bpy.types.Scene.motionkit_retarget
