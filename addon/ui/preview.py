"""The Retarget panel's live preview: Preview shows the retargeted clip on the target, remade whenever the
panel's map or options change (a timer compares them ten times a second), without writing into any
action the user has; Apply keys it as the Retarget button does (one undo step); Cancel puts the scene back
as it was (features/preview)."""
import bpy
from bpy.props import BoolProperty, FloatProperty, PointerProperty, StringProperty

from . import common
from ..features import preview

_INTERVAL = 0.1  # seconds between looks at the panel's settings
# The last settings shown, and how the target stood before the preview (features.preview.Held: its pose
# and transform live here, its action on the panel, a user of it).
_SHOWN = {"signature": None, "held": None}


class MOTIONKIT_PG_retarget_preview(bpy.types.PropertyGroup):
    on: BoolProperty(name="Previewing", default=False)
    target: PointerProperty(name="Target", type=bpy.types.Object)
    action: PointerProperty(name="Preview", type=bpy.types.Action)
    # What the target played: kept here (a user of it) while the preview plays instead.
    held: PointerProperty(name="Held", type=bpy.types.Action)
    held_slot: StringProperty(name="Held Slot")
    seconds: FloatProperty(name="Seconds")
    message: StringProperty(name="Message")


def _settings():
    return bpy.context.scene.motionkit_retarget


def _signature(settings) -> str:
    """Everything the preview depends on, as text: a change of any is a change of this."""
    return repr((settings.source.name if settings.source else None,
                 settings.source.animation_data.action.name if settings.source and settings.source.animation_data
                 and settings.source.animation_data.action else None,
                 settings.target.name if settings.target else None,
                 [(p.source, p.target, p.use) for p in settings.pairs],
                 (settings.frame_start, settings.frame_end) if settings.use_frame_range else None,
                 _options_text(settings)))


def _options_text(settings) -> str:
    """The panel's retarget options as text, or what is wrong with them (a channel map row half filled in):
    the preview is remade, and says so, when they change either way."""
    try:
        return repr(settings.retarget_options())
    except ValueError as error:
        return f"error: {error}"


def refresh(settings) -> None:
    """The preview remade from the panel's settings now; an error is shown in the panel, the last preview
    kept."""
    state = settings.preview
    _SHOWN["signature"] = _signature(settings)
    frame_range = (settings.frame_start, settings.frame_end) if settings.use_frame_range else None
    try:
        shown = preview.show(settings.source, state.target, settings.bone_map() or None, frame_range,
                             settings.retarget_options(), _held(state), state.action)
    except ValueError as error:
        state.message = str(error)
        return
    state.action, state.seconds, state.message = shown.action, shown.seconds, ""


def _tick():
    scene = bpy.context.scene
    settings = getattr(scene, "motionkit_retarget", None) if scene else None
    if settings is None or not settings.preview.on:
        return None
    if settings.target != settings.preview.target:
        stop(settings)
        return None
    if _signature(settings) != _SHOWN["signature"]:
        refresh(settings)
    return _INTERVAL


def stop(settings) -> None:
    """The scene as it was before the preview started."""
    state = settings.preview
    if not state.on:
        return
    target = state.target
    if target is not None:
        preview.stop(target, _held(state), state.action)
    elif state.action is not None:
        bpy.data.actions.remove(state.action)
    state.on, state.target, state.action, state.held, state.held_slot = False, None, None, None, ""
    _SHOWN["signature"] = _SHOWN["held"] = None


def _held(state) -> preview.Held:
    """How the target stood before the preview: as start() read it, or (a file opened mid-preview) its
    action alone."""
    held = _SHOWN["held"]
    if held is None or state.target is None:
        return preview.Held((state.held, state.held_slot or None), {}, state.target.matrix_basis.copy()
                            if state.target else None)
    return held


class MOTIONKIT_OT_retarget_preview(bpy.types.Operator):
    """Show the retargeted clip on the target, updated as the map and options change, without keying it
    (MotionKit)"""
    bl_idname = "motionkit.retarget_preview"
    bl_label = "Preview"
    bl_options = {'REGISTER'}

    @classmethod
    def poll(cls, context):
        settings = context.scene.motionkit_retarget
        if not common.poll_native(cls):
            return False
        if settings.source_kind != 'ARMATURE' or settings.source is None or settings.target is None:
            cls.poll_message_set("Pick a source armature and a target (import a file first)")
            return False
        return not settings.preview.on

    def execute(self, context):
        settings = context.scene.motionkit_retarget
        state = settings.preview
        held = preview.start(settings.target)
        _SHOWN["held"] = held
        action, slot = held.assignment
        state.on, state.target, state.held, state.held_slot = True, settings.target, action, slot or ""
        refresh(settings)
        if state.message:
            self.report({'WARNING'}, state.message)
        if not bpy.app.timers.is_registered(_tick):
            bpy.app.timers.register(_tick, first_interval=_INTERVAL)
        return {'FINISHED'}


class MOTIONKIT_OT_retarget_preview_cancel(bpy.types.Operator):
    """Stop the preview: the target plays what it played before (MotionKit)"""
    bl_idname = "motionkit.retarget_preview_cancel"
    bl_label = "Cancel"
    bl_options = {'REGISTER'}

    @classmethod
    def poll(cls, context):
        return context.scene.motionkit_retarget.preview.on

    def execute(self, context):
        stop(context.scene.motionkit_retarget)
        return {'FINISHED'}


@bpy.app.handlers.persistent
def _stop_on_load(_):
    """A file saved while previewing opens as it was before the preview."""
    settings = getattr(bpy.context.scene, "motionkit_retarget", None)
    if settings is not None and settings.preview.on:
        stop(settings)


def register():
    bpy.app.handlers.load_post.append(_stop_on_load)


def unregister():
    if _stop_on_load in bpy.app.handlers.load_post:
        bpy.app.handlers.load_post.remove(_stop_on_load)
    if bpy.app.timers.is_registered(_tick):
        bpy.app.timers.unregister(_tick)


classes = (MOTIONKIT_OT_retarget_preview, MOTIONKIT_OT_retarget_preview_cancel)
