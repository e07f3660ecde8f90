"""Planted feet in the UI: the contact thresholds as Blender properties (one table for the Retarget
panel's Plant Feet settings and the Fix Foot Sliding operator's redo panel; foot_contacts.ContactSettings
holds the numbers), and Fix Foot Sliding, the operator behind motionkit.contacts.plant (any armature's
action; Pose menu and the MotionKit tab)."""
import bpy
from bpy.props import FloatProperty

from . import common
from ..core.foot_contacts import ContactSettings
from ..features import contacts

_DEFAULTS = ContactSettings()
# name -> (label, minimum, maximum, unit, description); leg lengths and seconds, as ContactSettings.
_FIELDS = {
    "height_enter": ("Height In", 0.001, 1.0, 'NONE',
                     "A foot point enters a contact this close to its standing height (leg lengths)"),
    "height_leave": ("Height Out", 0.001, 1.0, 'NONE', "...and leaves it higher than this (leg lengths)"),
    "speed_enter": ("Speed In", 0.001, 10.0, 'NONE',
                    "A foot point enters a contact slower than this (leg lengths per second)"),
    "speed_leave": ("Speed Out", 0.001, 10.0, 'NONE',
                    "...and leaves it faster than this (leg lengths per second)"),
    "min_length": ("Shortest", 0.0, 2.0, 'TIME_ABSOLUTE', "Contacts shorter than this are ignored"),
    "max_drift": ("Drift", 0.001, 1.0, 'NONE',
                  "A contact whose foot point wanders farther than this across the floor is a slide or a pivot, "
                  "not planted (leg lengths)"),
    "max_pivot": ("Pivot", 0.001, 1.0, 'NONE',
                  "A foot point wandering farther than this about its still partner turns the foot about it: "
                  "only the partner is planted (leg lengths)"),
    "max_turn": ("Turn", 0.1, 180.0, 'NONE',
                 "A contact through which the foot turns farther than this across the floor (degrees) is a "
                 "swivel, not planted"),
    "blend": ("Blend", 0.001, 2.0, 'TIME_ABSOLUTE', "How long the feet take to ease into and out of a plant"),
}


def properties() -> dict:
    """Annotations for a class that holds the thresholds (an Operator or a PropertyGroup)."""
    return {name: FloatProperty(name=label, default=getattr(_DEFAULTS, name), min=low, max=high, precision=3,
                                unit=unit, description=description)
            for name, (label, low, high, unit, description) in _FIELDS.items()}


def settings(holder) -> ContactSettings:
    """ContactSettings from a holder of properties(); the leave thresholds never below the enter ones."""
    values = {name: getattr(holder, name) for name in _FIELDS}
    values["height_leave"] = max(values["height_leave"], values["height_enter"])
    values["speed_leave"] = max(values["speed_leave"], values["speed_enter"])
    return ContactSettings(**values)


# What a contact may do and still be held (a slide, a pivot and a swivel are not): drawn apart, they are
# seldom changed.
MOTION_FIELDS = ("max_drift", "max_pivot", "max_turn")


def draw(layout, holder, fields=None) -> None:
    """The thresholds' fields (default: all but MOTION_FIELDS)."""
    col = layout.column(align=True)
    for name in fields or [f for f in _FIELDS if f not in MOTION_FIELDS]:
        col.prop(holder, name)


class MOTIONKIT_PG_contacts(bpy.types.PropertyGroup):
    __annotations__ = properties()


class MOTIONKIT_OT_fix_foot_sliding(bpy.types.Operator):
    """Detect foot contacts (or read the edited contact curves) and hold planted feet with full-body IK
    (MotionKit)"""
    bl_idname = "motionkit.fix_foot_sliding"
    bl_label = "Fix Foot Sliding"
    bl_options = {'REGISTER', 'UNDO'}

    __annotations__ = {
        "use_scene_range": bpy.props.BoolProperty(
            name="Scene Range", default=False,
            description="Hold contacts in the scene's frame range only (else the whole action)"),
        "redetect": bpy.props.BoolProperty(
            name="Detect Again", default=False,
            description="Detect contacts anew and replace the contact curves (else the curves are read when "
                        "the action has them)"),
        **properties(),
    }

    @classmethod
    def poll(cls, context):
        if not common.poll_native(cls):
            return False
        obj = context.object
        if obj is None or obj.type != 'ARMATURE' or obj.animation_data is None \
                or obj.animation_data.action is None:
            cls.poll_message_set("Select an armature with an action")
            return False
        return True

    def execute(self, context):
        obj = context.object
        scene = context.scene
        frame_range = (scene.frame_start, scene.frame_end) if self.use_scene_range else None

        def message(report):
            count = sum(len(runs) for runs in report.intervals)
            return (f"Held {count} foot contacts ({report.source}) on '{obj.name}' in "
                    f"{report.seconds * 1000:.0f} ms, largest miss {report.max_error.max():.2e}")

        return common.run(
            self, context,
            lambda progress: contacts.plant(obj, frame_range, settings(self), redetect=self.redetect),
            message)


def menu_pose(self, context):
    self.layout.operator(MOTIONKIT_OT_fix_foot_sliding.bl_idname)


classes = (MOTIONKIT_PG_contacts, MOTIONKIT_OT_fix_foot_sliding)
