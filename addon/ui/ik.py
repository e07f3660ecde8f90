"""Full-body IK in the UI: its settings (kept on each armature object, object.motionkit_ik), the
effector list, the Solve and Bake operators, the Live toggle (features.ik_live) and the panel."""
import bpy
from bpy.props import (BoolProperty, CollectionProperty, EnumProperty, FloatProperty, IntProperty,
                       PointerProperty, StringProperty)

from . import common
from ..core import display_names, ik_defaults
from ..features import ik, ik_live


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
    chain_count: IntProperty(name="Chain", default=0, min=0, max=255,
                             description="Bones this effector moves, up from its bone; 0: up to the root")

    def effector(self) -> ik.Effector:
        target = self.target
        if target is not None and target.type == 'ARMATURE' and self.subtarget:
            target = (target, self.subtarget)
        return ik.Effector(self.bone, None if self.pin else target, self.pin, self.weight, self.use_position,
                           self.use_orientation, name=f"effector on '{self.bone}'", chain_count=self.chain_count)


# The natural defaults' settings (core.ik_defaults.NaturalDefaults), one property each: (label, unit).
_DEFAULT_LABELS = {
    "spine_stiffness": ("Spine", ""), "clavicle_stiffness": ("Clavicles", ""), "hips_stiffness": ("Hips", ""),
    "spine_flexion": ("Bend Forward", "deg"), "spine_extension": ("Bend Back", "deg"),
    "spine_side": ("Bend Sideways", "deg"), "spine_twist": ("Twist", "deg"),
    "clavicle_range": ("Clavicle", "deg"), "hip_flexion": ("Hip Forward", "deg"), "hip_extension": ("Hip Back", "deg"),
    "hip_side": ("Hip Sideways", "deg"), "hip_twist": ("Hip Twist", "deg"), "knee_bend": ("Knee Bend", "deg"),
    "elbow_bend": ("Elbow Bend", "deg"), "forearm_twist": ("Forearm Twist", "deg"),
    "upper_arm_twist": ("Upper Arm Twist", "deg"), "wrist_flexion": ("Wrist Bend", "deg"),
    "wrist_side": ("Wrist Sideways", "deg"), "ankle_range": ("Ankle", "deg"),
}


def _default_property(name, value):
    label, unit = _DEFAULT_LABELS[name]
    if unit:
        return FloatProperty(name=label, default=value, min=0.0, max=180.0, precision=0,
                             description=f"Natural defaults: {label.lower()}, degrees")
    return FloatProperty(name=label, default=value, min=0.0, max=0.99, precision=2,
                         description=f"Natural defaults: the {label.lower()}' stiffness (0 free, towards 1 stiff)")


class MOTIONKIT_PG_ik_defaults(bpy.types.PropertyGroup):
    """The natural defaults' editable settings (core.ik_defaults.NaturalDefaults)."""
    __annotations__ = {name: _default_property(name, value)
                       for name, value in ik_defaults.NaturalDefaults().to_dict().items()}

    def values(self) -> dict:
        return {name: getattr(self, name) for name in ik_defaults.NaturalDefaults().to_dict()}


class MOTIONKIT_PG_ik(bpy.types.PropertyGroup):
    effectors: CollectionProperty(type=MOTIONKIT_PG_ik_effector)
    natural: EnumProperty(
        name="Natural Defaults", default="AUTO",
        items=(("AUTO", "Auto", "On for a humanoid the bone map recognises"), ("ON", "On", "Humanoids only"),
               ("OFF", "Off", "Every joint free, as the rig sets it")),
        description="Distal joints first (arm, then spine, then hips), human joint ranges and stiffness "
                    "where the rig sets none, masses for the balance")
    balance: EnumProperty(
        name="Balance", default="AUTO",
        items=(("AUTO", "Auto", "On when a humanoid's feet are pinned"), ("ON", "On", "Whenever a bone is pinned"),
               ("OFF", "Off", "No balance")),
        description="Keep the centre of mass over the pinned feet (the hips move to hold it)")
    defaults: PointerProperty(type=MOTIONKIT_PG_ik_defaults)
    active_effector: IntProperty(name="Active Effector")
    method: EnumProperty(name="Method", items=ik.METHODS, default="dls")
    max_iterations: IntProperty(name="Iterations", default=64, min=1, max=10000)
    damping: FloatProperty(name="Damping", default=0.0, min=0.0, max=1e3, precision=4,
                           description="Lambda of damped least squares; 0 picks one from the rig's size")
    regularization: FloatProperty(name="Smoothing", default=0.0, min=0.0, max=1e3, precision=5,
                                  description="The posture prior: the pull towards the input pose (natural "
                                              f"defaults) or the previous frame's; 0 picks "
                                              f"{ik.NATURAL_REGULARIZATION:g} for a humanoid, else "
                                              f"{ik.PLAIN_REGULARIZATION:g}")
    root_translation: BoolProperty(name="Move", default=True, description="The root's location is solved")
    root_rotation: BoolProperty(name="Rotate", default=True, description="The root's rotation is solved")
    use_limits: BoolProperty(name="Limits", default=True,
                             description="Respect the bones' IK limits, locks and stiffness")
    live: BoolProperty(name="Live", update=_live_changed,
                       description="Re-solve the current frame whenever a target moves or the frame changes")
    use_scene_range: BoolProperty(name="Scene Range", default=True, description="Bake the scene's frame range")
    frame_start: IntProperty(name="Start", default=1)
    frame_end: IntProperty(name="End", default=250)
    new_action: BoolProperty(name="New Action", default=True,
                             description="Bake into a copy of the current action; else into the current one")

    def effector_list(self) -> list:
        return [e.effector() for e in self.effectors if e.bone]

    def live_settings(self) -> ik_live.LiveSettings | None:
        """What Live IK re-solves with, or None while Live is off."""
        return ik_live.LiveSettings(self.effector_list(), self.method, self.options()) if self.live else None

    def options(self) -> dict:
        return {"root_translation": self.root_translation, "root_rotation": self.root_rotation,
                "max_iterations": self.max_iterations, "damping": self.damping,
                "regularization": self.regularization, "use_limits": self.use_limits,
                "natural": {"AUTO": "auto", "ON": True, "OFF": False}[self.natural],
                "balance": {"AUTO": None, "ON": True, "OFF": False}[self.balance],
                "defaults": self.defaults.values()}


def _armature(context):
    obj = context.object
    return obj if obj is not None and obj.type == 'ARMATURE' else None


def _poll_effectors(cls, context) -> bool:
    if not common.poll_native(cls):
        return False
    obj = _armature(context)
    if obj is None:
        cls.poll_message_set("Select an armature")
        return False
    if not any(e.bone for e in obj.motionkit_ik.effectors):
        cls.poll_message_set("Add an effector")
        return False
    return True


class _EffectorsOperator:
    """What Solve and Bake share: one undo step, and an armature with effectors to run on."""
    bl_options = {'REGISTER', 'UNDO'}

    @classmethod
    def poll(cls, context):
        return _poll_effectors(cls, context)


class MOTIONKIT_OT_ik_solve(_EffectorsOperator, bpy.types.Operator):
    """Solve full-body IK on the current frame and pose the armature (MotionKit)"""
    bl_idname = "motionkit.ik_solve"
    bl_label = "Solve"

    def execute(self, context):
        obj = _armature(context)
        settings = obj.motionkit_ik
        return common.run(
            self, context,
            lambda progress: ik.solve(obj, settings.effector_list(), None, settings.method, **settings.options()),
            lambda result: f"Solved in {int(result.iterations[0])} iterations, largest error "
                           f"{result.errors.max():.2e}")


class MOTIONKIT_OT_ik_bake(_EffectorsOperator, bpy.types.Operator):
    """Solve full-body IK on every frame of a range and key the solved bones (MotionKit)"""
    bl_idname = "motionkit.ik_bake"
    bl_label = "Bake"

    def execute(self, context):
        obj = _armature(context)
        settings = obj.motionkit_ik
        scene = context.scene
        frame_range = ((scene.frame_start, scene.frame_end) if settings.use_scene_range
                       else (settings.frame_start, settings.frame_end))

        def bake(progress):
            progress(0, 1)
            return ik.bake(obj, settings.effector_list(), frame_range, settings.method,
                           new_action=settings.new_action, **settings.options())

        return common.run(
            self, context, bake,
            lambda done: f"Baked {len(done[0].frames)} frames of {len(done[0].bones)} bones into "
                         f"'{done[1].name}'; largest error {done[0].errors.max():.2e}")


# The prefix the effectors' bone names share ("mixamorig:"), found once per draw of the panel.
_SHOWN_PREFIX = [""]


class MOTIONKIT_UL_ik_effectors(bpy.types.UIList):
    """One row per effector, as text: its bone, then an icon for pinned or reaching. Nothing in a row is a
    button, so a click picks the row (highlighted), whose settings the panel shows below the list."""

    def draw_item(self, context, layout, data, item, icon, active_data, active_propname, index=0):
        row = layout.row()
        row.label(text=display_names.strip(item.bone, _SHOWN_PREFIX[0]) or "(no bone)")
        # Pinned, reaching for an object, or missing its target: an icon, so the bone's name has the room.
        row.label(text="", icon='PINNED' if item.pin else 'OBJECT_DATA' if item.target is not None else 'ERROR')


class _IkPanel(common.SidebarPanel):
    """A panel under the IK panel, shown for an armature (Blender names each panel after its class)."""
    bl_parent_id = "MOTIONKIT_PT_ik"

    @classmethod
    def poll(cls, context):
        return _armature(context) is not None


class MOTIONKIT_PT_ik(common.SidebarPanel, bpy.types.Panel):
    """The effectors, the active one's settings, Solve and Live."""
    bl_label = "Full-body IK"

    def draw(self, context):
        layout = self.layout
        obj = _armature(context)
        if obj is None:
            layout.label(text="Select an armature", icon='INFO')
            return
        settings = obj.motionkit_ik
        _SHOWN_PREFIX[0] = display_names.shared_prefix(e.bone for e in settings.effectors)
        layout.label(text=f"Effectors ({_SHOWN_PREFIX[0]}*)" if _SHOWN_PREFIX[0] else "Effectors")
        row = layout.row()
        row.template_list("MOTIONKIT_UL_ik_effectors", "", settings, "effectors", settings, "active_effector",
                          rows=4)
        common.draw_list_buttons(row.column(align=True), EFFECTORS.name)
        if 0 <= settings.active_effector < len(settings.effectors):
            self.draw_effector(settings.effectors[settings.active_effector], obj, layout.box())
        row = layout.row(align=True)
        row.scale_y = 1.3
        row.operator("motionkit.ik_solve", icon='CON_KINEMATIC')
        row.prop(settings, "live", toggle=True, text="Live: On" if settings.live else "Live: Off",
                 icon='REC' if settings.live else 'PLAY')

    @staticmethod
    def draw_effector(item, obj, box):
        """The active effector's own settings, under its name."""
        box.label(text="Selected Effector")
        col = box.column(align=True)
        col.prop_search(item, "bone", obj.data, "bones", text="", icon='BONE_DATA')
        col.prop(item, "pin", toggle=True, icon='PINNED' if item.pin else 'UNPINNED',
                 text="Pinned where it stands" if item.pin else "Pin")
        if not item.pin:
            col.prop(item, "target", text="", icon='OBJECT_DATA')
            if item.target is not None and item.target.type == 'ARMATURE':
                col.prop_search(item, "subtarget", item.target.data, "bones", text="", icon='BONE_DATA')
        row = box.row(align=True)
        row.prop(item, "use_position", toggle=True)
        row.prop(item, "use_orientation", toggle=True)
        col = common.split_layout(box.column(align=True))
        col.prop(item, "weight")
        col.prop(item, "chain_count")


class MOTIONKIT_PT_ik_solver(_IkPanel, bpy.types.Panel):
    bl_label = "Solver"
    bl_options = {'DEFAULT_CLOSED'}

    def draw(self, context):
        settings = _armature(context).motionkit_ik
        layout = common.split_layout(self.layout)
        layout.prop(settings, "method")
        col = layout.column(align=True)
        col.prop(settings, "max_iterations")
        col.prop(settings, "damping")
        col.prop(settings, "regularization")
        common.draw_groups(layout, settings, (("Root", ("root_translation", "root_rotation")),
                                              ("Joints", ("use_limits",))))


class MOTIONKIT_PT_ik_natural(_IkPanel, bpy.types.Panel):
    """Natural defaults and balance: what they are on this rig, and their settings."""
    bl_label = "Natural Defaults"
    bl_options = {'DEFAULT_CLOSED'}

    def draw(self, context):
        obj = _armature(context)
        settings = obj.motionkit_ik
        layout = common.split_layout(self.layout)
        layout.prop(settings, "natural")
        layout.prop(settings, "balance")
        humanoid = ik.is_humanoid(obj)
        layout.label(text="Humanoid: defaults apply" if humanoid else "Not a humanoid: no defaults",
                     icon='ARMATURE_DATA' if humanoid else 'INFO')
        d = settings.defaults
        active = humanoid and settings.natural != "OFF"
        for heading, names in (("Stiffness", ("spine_stiffness", "clavicle_stiffness", "hips_stiffness")),
                               ("Spine", ("spine_flexion", "spine_extension", "spine_side", "spine_twist")),
                               ("Arms", ("clavicle_range", "upper_arm_twist", "elbow_bend", "forearm_twist",
                                         "wrist_flexion", "wrist_side")),
                               ("Legs", ("hip_flexion", "hip_extension", "hip_side", "hip_twist", "knee_bend",
                                         "ankle_range"))):
            col = layout.column(align=True, heading=heading)
            col.active = active
            for name in names:
                col.prop(d, name)


class MOTIONKIT_PT_ik_bake(_IkPanel, bpy.types.Panel):
    bl_label = "Bake"

    def draw(self, context):
        settings = _armature(context).motionkit_ik
        layout = common.split_layout(self.layout)
        common.draw_frame_range(layout, settings, "use_scene_range", "Frames", frames_when=False)
        col = layout.column(heading="Keys")
        col.prop(settings, "new_action")
        layout.operator("motionkit.ik_bake", icon='REC')


def _add_on_active_bone(context, item):
    if context.active_pose_bone is not None:
        item.bone = context.active_pose_bone.name


EFFECTORS = common.editable_list(common.EditableList(
    "ik_effectors", "effector", lambda context: obj.motionkit_ik if (obj := _armature(context)) else None,
    "effectors", "active_effector", "Select an armature", _add_on_active_bone))

classes = (MOTIONKIT_PG_ik_effector, MOTIONKIT_PG_ik_defaults, MOTIONKIT_PG_ik, MOTIONKIT_OT_ik_solve,
           MOTIONKIT_OT_ik_bake, MOTIONKIT_UL_ik_effectors, MOTIONKIT_PT_ik, MOTIONKIT_PT_ik_solver,
           MOTIONKIT_PT_ik_natural, MOTIONKIT_PT_ik_bake)


def live_settings(obj) -> ik_live.LiveSettings | None:
    """An armature's Live IK settings from its property group (features.ik_live asks through this)."""
    return obj.motionkit_ik.live_settings()


def register_properties():
    bpy.types.Object.motionkit_ik = PointerProperty(type=MOTIONKIT_PG_ik)


def unregister_properties():
    del bpy.types.Object.motionkit_ik
