"""The Full-body IK panel's settings, kept on each armature object (object.motionkit_ik)."""
import bpy
from bpy.props import (BoolProperty, CollectionProperty, EnumProperty, FloatProperty, IntProperty,
                       PointerProperty, StringProperty)

from . import ik, ik_live


def _live_changed(self, context):
    ik_live.sync()


class MOTIONKIT_PG_ik_effector(bpy.types.PropertyGroup):
    bone: StringProperty(name="Bone", description="The bone whose tail reaches the target")
    target: PointerProperty(name="Target", type=bpy.types.Object,
                            description="The object (or armature, with a bone) to reach")
    subtarget: StringProperty(name="Target Bone", description="With an armature target: the bone whose head to reach")
    pin: BoolProperty(name="Pin", description="Hold the tail where the pose has it, instead of a target")
    weight: FloatProperty(name="Weight", default=1.0, min=1e-3, max=1e3)
    use_position: BoolProperty(name="Position", default=True)
    use_orientation: BoolProperty(name="Orientation", description="Also match the target's rotation")
    chain_count: IntProperty(name="Chain Length", default=0, min=0, max=255,
                             description="Bones this effector moves, up from its bone; 0: up to the root")

    def effector(self) -> ik.Effector:
        target = self.target
        if target is not None and target.type == 'ARMATURE' and self.subtarget:
            target = (target, self.subtarget)
        return ik.Effector(self.bone, None if self.pin else target, self.pin, self.weight, self.use_position,
                           self.use_orientation, name=f"effector on '{self.bone}'", chain_count=self.chain_count)


class MOTIONKIT_PG_ik(bpy.types.PropertyGroup):
    effectors: CollectionProperty(type=MOTIONKIT_PG_ik_effector)
    active_effector: IntProperty(name="Active Effector")
    method: EnumProperty(name="Method", items=ik.METHODS, default="dls")
    max_iterations: IntProperty(name="Iterations", default=64, min=1, max=10000)
    damping: FloatProperty(name="Damping", default=0.0, min=0.0, max=1e3, precision=4,
                           description="Lambda of damped least squares; 0 picks one from the rig's size")
    regularization: FloatProperty(name="Regularisation", default=1e-4, min=0.0, max=1e3, precision=5,
                                  description="Pull towards the previous frame's pose")
    root_translation: BoolProperty(name="Move Root", default=True, description="The root's location is solved")
    root_rotation: BoolProperty(name="Turn Root", default=True, description="The root's rotation is solved")
    use_limits: BoolProperty(name="Joint Limits", default=True,
                             description="Respect the bones' IK limits, locks and stiffness")
    live: BoolProperty(name="Live", update=_live_changed,
                       description="Re-solve the current frame whenever a target moves or the frame changes")
    use_scene_range: BoolProperty(name="Scene Frame Range", default=True)
    frame_start: IntProperty(name="Start", default=1)
    frame_end: IntProperty(name="End", default=250)
    new_action: BoolProperty(name="New Action", default=True,
                             description="Bake into a copy of the current action; else into the current one")

    def effector_list(self) -> list:
        return [e.effector() for e in self.effectors if e.bone]

    def options(self) -> dict:
        return {"root_translation": self.root_translation, "root_rotation": self.root_rotation,
                "max_iterations": self.max_iterations, "damping": self.damping,
                "regularization": self.regularization, "use_limits": self.use_limits}


classes = (MOTIONKIT_PG_ik_effector, MOTIONKIT_PG_ik)


def register_properties():
    bpy.types.Object.motionkit_ik = PointerProperty(type=MOTIONKIT_PG_ik)


def unregister_properties():
    del bpy.types.Object.motionkit_ik
