"""What MotionKit's operators and panels share: run the work with progress and report the outcome, say
whether the native core is usable, and one operator that adds to or removes from any of MotionKit's
lists (the bone map, the IK effectors), as rigify has one for its lists.

An error the work raises (bad input, a bad file) is reported and the operator
cancels; the work computes everything before it changes the file, so nothing
has changed.
"""
from __future__ import annotations

from dataclasses import dataclass

import blf
import bpy
from bpy.props import EnumProperty, StringProperty

from ..core import display_names, native_state


# The width a list row's split shares out is the sidebar's less the panel's margins and the list's box, less
# the scroll bar's when the list has one; a label keeps some of its column clear. Pixels at scale 1, read off
# screenshots at the default sidebar width (Blender 4 widened the list's box and its scroll bar).
LIST_MARGIN_PX, SCROLL_BAR_PX = (64, 18) if bpy.app.version >= (4, 0, 0) else (55, 17)
LABEL_PADDING_PX = 12
ICON_PX = 28  # an icon and the space after it


def set_interface_font(context) -> float:
    """Sets blf's default font to the size the interface draws labels at; returns the interface's scale."""
    scale = context.preferences.system.ui_scale or 1.0
    blf.size(0, context.preferences.ui_styles[0].widget.points * scale)
    return scale


def text_width(text: str) -> float:
    return blf.dimensions(0, text)[0]


def fit_label(context, text: str, share: float, scrolls: bool = False, icon: bool = False) -> str:
    """text cut in the middle to fit the column that takes share of a list row (after an icon, if any), as
    the interface draws it."""
    scale = set_interface_font(context)
    row = context.region.width - (LIST_MARGIN_PX + SCROLL_BAR_PX * scrolls) * scale
    room = row * share - (LABEL_PADDING_PX + ICON_PX * icon) * scale
    return display_names.fit_width(text, room, text_width)


class Progress:
    """progress(done, total) for the window manager's progress bar, begun on the first call."""

    def __init__(self, context):
        self.wm = context.window_manager
        self.started = False

    def __call__(self, done, total):
        if not self.started:
            self.wm.progress_begin(0, max(total, 1))
            self.started = True
        self.wm.progress_update(done)

    def end(self):
        if self.started:
            self.wm.progress_end()


def run(operator, context, work, done_message) -> set:
    """work(progress) -> result; done_message(result) -> the report ('' for none)."""
    progress = Progress(context)
    try:
        result = work(progress)
    except (ValueError, TypeError, OSError) as ex:
        operator.report({'ERROR'}, str(ex))
        return {'CANCELLED'}
    finally:
        progress.end()
    message = done_message(result)
    if message:
        operator.report({'INFO'}, message)
    return {'FINISHED'}


def poll_native(operator_class) -> bool:
    """For an operator's poll: False, with the reason shown, when the core is not usable."""
    if not native_state.status.ok:
        operator_class.poll_message_set(native_state.status.message)
        return False
    return True


def poll_active_armature(operator_class, context):
    """For an operator's poll: the active armature object, or None with the reason shown (the core not
    usable, or no armature active)."""
    if not poll_native(operator_class):
        return None
    obj = context.active_object
    if obj is None or obj.type != 'ARMATURE':
        operator_class.poll_message_set("Make an armature the active object")
        return None
    return obj


def draw_status(layout, compact: bool = False) -> None:
    """Draws the core's versions (compact: only MotionKit's, for the sidebar's width), or the reason it did
    not load, in a UI layout."""
    status = native_state.status
    if status.ok:
        info = status.module.build_info()
        if compact:
            layout.label(text=f"MotionKit {info['version']} ready", icon='CHECKMARK')
            return
        col = layout.column(align=True)
        col.label(text=f"MotionKit {info['version']}: native core loaded", icon='CHECKMARK')
        col.label(text=f"Eigen {info['eigen']}, pybind11 {info['pybind11']}, Python {info['python']}")
        return
    box = layout.box()
    box.alert = True
    col = box.column(align=True)
    col.label(text="MotionKit cannot run in this Blender:", icon='ERROR')
    # The message is long; split it into label-sized lines (the sidebar's are short).
    words, line = status.message.split(), ""
    for word in words:
        if len(line) + len(word) > (28 if compact else 70):
            col.label(text=line)
            line = ""
        line += (" " if line else "") + word
    if line:
        col.label(text=line)


class SidebarPanel:
    """What every panel of the MotionKit tab in the 3D view's sidebar shares."""
    bl_space_type = 'VIEW_3D'
    bl_region_type = 'UI'
    bl_category = "MotionKit"


def split_layout(layout):
    """A layout with labels in a column on the left, as Blender's own panels draw properties."""
    layout.use_property_split = True
    layout.use_property_decorate = False
    return layout


def draw_groups(layout, holder, groups) -> None:
    """Columns of the holder's properties under headings: groups is ((heading or "", (property or
    (property, label), ...)), ...)."""
    for heading, props in groups:
        col = layout.column(heading=heading)
        for prop in props:
            name, label = (prop, None) if isinstance(prop, str) else prop
            col.prop(holder, name, **({} if label is None else {"text": label}))


def draw_frame_range(layout, holder, toggle: str, heading: str, frames_when: bool = True) -> None:
    """A checkbox under a heading and, when it is `frames_when`, the holder's frame_start and frame_end."""
    col = layout.column(heading=heading)
    col.prop(holder, toggle)
    if getattr(holder, toggle) == frames_when:
        sub = col.column(align=True)
        sub.prop(holder, "frame_start")
        sub.prop(holder, "frame_end", text="End")


# ---------------------------------------------------------------------------
# Lists

@dataclass
class EditableList:
    """One of MotionKit's lists, as the generic list operator edits it."""
    name: str            # the operator's list= value
    item: str            # what one item is called ("pair", "effector")
    holder: object       # (context) -> the property group holding the collection, or None
    collection: str
    active: str          # the holder's index property of the active item
    missing: str         # why there is no holder ("Select an armature")
    on_add: object = None  # (context, item): fills in a new item


LISTS: dict[str, EditableList] = {}


def editable_list(spec: EditableList) -> EditableList:
    LISTS[spec.name] = spec
    return spec


def draw_list_buttons(layout, name: str) -> None:
    """The + and - buttons beside a template_list."""
    for action, icon in (('ADD', 'ADD'), ('REMOVE', 'REMOVE')):
        op = layout.operator(MOTIONKIT_OT_list_edit.bl_idname, text="", icon=icon)
        op.list, op.action = name, action


class MOTIONKIT_OT_list_edit(bpy.types.Operator):
    """Add an item to a MotionKit list, or remove its active item"""
    bl_idname = "motionkit.list_edit"
    bl_label = "Edit List"
    bl_options = {'REGISTER', 'UNDO', 'INTERNAL'}

    list: StringProperty(name="List", options={'HIDDEN'})
    action: EnumProperty(name="Action", items=[('ADD', "Add", "Add an item"),
                                               ('REMOVE', "Remove", "Remove the active item")])

    @classmethod
    def description(cls, context, properties):
        spec = LISTS.get(properties.list)
        what = spec.item if spec else "item"
        return f"Add a {what}" if properties.action == 'ADD' else f"Remove the selected {what}"

    def execute(self, context):
        spec = LISTS.get(self.list)
        if spec is None:
            self.report({'ERROR'}, f"MotionKit has no list '{self.list}'")
            return {'CANCELLED'}
        holder = spec.holder(context)
        if holder is None:
            self.report({'ERROR'}, spec.missing)
            return {'CANCELLED'}
        items = getattr(holder, spec.collection)
        active = getattr(holder, spec.active)
        if self.action == 'ADD':
            item = items.add()
            if spec.on_add is not None:
                spec.on_add(context, item)
            setattr(holder, spec.active, len(items) - 1)
            return {'FINISHED'}
        if not 0 <= active < len(items):
            self.report({'ERROR'}, f"Select a {spec.item}")
            return {'CANCELLED'}
        items.remove(active)
        setattr(holder, spec.active, min(active, len(items) - 1))
        return {'FINISHED'}


classes = (MOTIONKIT_OT_list_edit,)
