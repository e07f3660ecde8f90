"""A motion library in the sidebar: a folder of clips retargeted onto the Retarget panel's target, and the
batch's report as a list sorted by what needs a look, a row's figures under it (features/batch)."""
import dataclasses

import bpy
from bpy.props import BoolProperty, CollectionProperty, EnumProperty, FloatProperty, IntProperty, PointerProperty, StringProperty

from . import common, retarget
from ..features import batch

EXPORT_ITEMS = (("NONE", "Keep Actions", "Only the actions in this file"),
                *((kind.upper(), kind.upper(), f"Each clip also written as {kind.upper()} into the output folder")
                  for kind in batch.EXPORTS))
SORT_ITEMS = (("sliding_worst_mm", "Foot Sliding", "The clips whose feet slide most first"),
              ("floor_worst_mm", "Off the Floor", "The clips whose feet stand farthest off the floor first"),
              ("direction_worst_deg", "Direction", "The clips whose bones point farthest from the source's first"),
              ("pop_worst_deg", "Pops", "The clips with the largest jumps first"),
              ("order", "File Order", "As the files were read"))
_FIGURES = ("frames", "fingers_mapped", "sliding_worst_mm", "sliding_median_mm", "floor_above_mm",
            "floor_below_mm", "direction_worst_deg", "pop_worst_deg", "seconds")
NOT_MEASURED = -1.0
NAME_SHARE = 0.62  # of a report row: the clip's name, then its figure
LIST_ROWS = 12  # a figure the clip has nothing to measure with (no feet, no stance)


class MOTIONKIT_PG_batch_row(bpy.types.PropertyGroup):
    action: StringProperty()
    file: StringProperty()
    status: StringProperty()
    reason: StringProperty()
    order: IntProperty()
    frames: IntProperty()
    fingers_mapped: IntProperty()
    bones_mapped: IntProperty()
    sliding_worst_mm: FloatProperty(default=NOT_MEASURED)
    sliding_median_mm: FloatProperty(default=NOT_MEASURED)
    floor_above_mm: FloatProperty(default=NOT_MEASURED)
    floor_below_mm: FloatProperty(default=NOT_MEASURED)
    floor_worst_mm: FloatProperty(default=NOT_MEASURED)
    direction_worst_deg: FloatProperty(default=NOT_MEASURED)
    pop_worst_deg: FloatProperty(default=NOT_MEASURED)
    seconds: FloatProperty()


class MOTIONKIT_PG_batch(bpy.types.PropertyGroup):
    folder: StringProperty(name="Clips", subtype='DIR_PATH', description="The folder of motion files (and its subfolders)")
    pattern: StringProperty(name="Names", default="*", description="Only files whose names match, as *.fbx")
    export: EnumProperty(name="Output", items=EXPORT_ITEMS, default="NONE")
    out_dir: StringProperty(name="Folder", subtype='DIR_PATH',
                            description="Where the clips and the report (report.csv, report.json) are written")
    rows: CollectionProperty(type=MOTIONKIT_PG_batch_row)
    active_row: IntProperty()
    sort_by: EnumProperty(name="Sort", items=SORT_ITEMS, default="sliding_worst_mm")
    use_bone_map: BoolProperty(name="Panel's Bone Map",
                               description="Pair every file's bones by the Retarget panel's bone map (the files "
                                           "share its source's skeleton); off: each file is mapped by its own "
                                           "bone names")


def _fill_rows(settings, rows) -> None:
    settings.rows.clear()
    for order, row in enumerate(rows):
        item = settings.rows.add()
        item.action, item.file, item.status, item.reason, item.order = (
            row["action"], row["file"], row["status"], row["reason"] or "", order)
        for key in _FIGURES + ("bones_mapped",):
            if row.get(key) is not None:
                setattr(item, key, row[key])
        if row.get("floor_above_mm") is not None:
            item.floor_worst_mm = max(row["floor_above_mm"], row["floor_below_mm"])
    settings.active_row = 0


class MOTIONKIT_OT_retarget_library(bpy.types.Operator):
    """Retarget every take of every motion file of a folder onto the target: one action per take, a report
    row per clip, a bad file reported and skipped (MotionKit)"""
    bl_idname = "motionkit.retarget_library"
    bl_label = "Retarget Library"
    bl_options = {'REGISTER', 'UNDO'}

    @classmethod
    def poll(cls, context):
        target = context.scene.motionkit_retarget.target
        if target is None:
            cls.poll_message_set("Pick the target armature in the Retarget panel")
            return False
        if not context.scene.motionkit_batch.folder:
            cls.poll_message_set("Pick the folder of clips")
            return False
        return common.poll_native(cls)

    def execute(self, context):
        settings = context.scene.motionkit_batch
        panel = context.scene.motionkit_retarget
        target = panel.target
        export = None if settings.export == "NONE" else settings.export.lower()
        out_dir = bpy.path.abspath(settings.out_dir) or None

        def work(progress):
            return batch.retarget_library([bpy.path.abspath(settings.folder)], target, pattern=settings.pattern,
                                          out_dir=out_dir, export=export, report_dir=out_dir,
                                          progress=lambda done, total, path: progress(done, total),
                                          **library_options(panel, settings))

        def done(result):
            _fill_rows(settings, result.rows)
            ok = sum(row["status"] == "ok" for row in result.rows)
            return (f"{len(result.rows)} clips: {ok} retargeted onto '{target.name}', {result.failed} failed"
                    + (f"; the report is in {out_dir}" if out_dir else ""))

        return common.run(self, context, work, done)


def library_options(panel, settings) -> dict:
    """The Retarget panel's options as the batch takes them: each clip whole (the panel's frame range is its
    own source's) and a new action of its own (the parts the panel writes over a copy of the target's own),
    the panel's bone map only where asked."""
    chosen = dataclasses.replace(panel.retarget_options(), into="new")
    mapped = {"bone_map": panel.bone_map()} if settings.use_bone_map and panel.bone_map() else {}
    return {"options": chosen, **panel.control_keywords(), **mapped}


class MOTIONKIT_UL_batch_report(bpy.types.UIList):
    """One row per clip: its name, and the figure the list is sorted by (or why it failed)."""

    def draw_item(self, context, layout, data, item, icon, active_data, active_propname, index=0):
        split = layout.split(factor=NAME_SHARE)
        name = common.fit_label(context, item.action, NAME_SHARE, scrolls=len(data.rows) > LIST_ROWS, icon=True)
        split.label(text=name, icon='ERROR' if item.status == "failed" else 'ACTION')
        key = data.sort_by if data.sort_by != "order" else "sliding_worst_mm"
        value = getattr(item, key)
        unit = "°" if key.endswith("deg") else " mm"
        split.label(text=item.status if item.status != "ok" else ("-" if value < 0 else f"{value:.0f}{unit}"))

    def filter_items(self, context, data, propname):
        items = getattr(data, propname)
        key = data.sort_by
        if key == "order":
            order = sorted(range(len(items)), key=lambda i: items[i].order)
        else:  # failures first, then the worst figure
            order = sorted(range(len(items)), key=lambda i: (items[i].status == "ok", -getattr(items[i], key)))
        positions = [0] * len(items)
        for position, i in enumerate(order):
            positions[i] = position
        return [], positions


class MOTIONKIT_PT_retarget_batch(retarget.RetargetSubPanel, bpy.types.Panel):
    """A folder of clips onto the target, and the report of the last batch."""
    bl_label = "Library"

    def draw(self, context):
        settings = context.scene.motionkit_batch
        layout = self.layout
        layout.prop(settings, "folder")
        layout.prop(settings, "pattern")
        layout.prop(settings, "export")
        layout.prop(settings, "out_dir")
        layout.prop(settings, "use_bone_map")
        layout.label(text="Retarget panel's options", icon='INFO')
        layout.operator("motionkit.retarget_library", icon='FILE_FOLDER')
        if not settings.rows:
            return
        layout.prop(settings, "sort_by")
        layout.template_list("MOTIONKIT_UL_batch_report", "", settings, "rows", settings, "active_row",
                             rows=min(max(len(settings.rows), 4), LIST_ROWS))
        if 0 <= settings.active_row < len(settings.rows):
            _draw_row(layout.box(), settings.rows[settings.active_row])


def _draw_row(box, row) -> None:
    box.label(text=row.action)
    if row.status != "ok":
        for line in _wrap(row.reason, 34)[:6]:
            box.label(text=line)
        return

    def figure(value, unit):
        return "-" if value < 0 else f"{value:.1f}{unit}"

    for name, value in (("Frames", str(row.frames)), ("Bones", f"{row.bones_mapped} + {row.fingers_mapped} fingers"),
                        ("Sliding", figure(row.sliding_worst_mm, " mm")),
                        ("Median", figure(row.sliding_median_mm, " mm")),
                        ("Above Floor", figure(row.floor_above_mm, " mm")),
                        ("Below Floor", figure(row.floor_below_mm, " mm")),
                        ("Direction", figure(row.direction_worst_deg, "\u00b0")),
                        ("Pops", figure(row.pop_worst_deg, "\u00b0"))):
        split = box.split(factor=0.45)
        split.label(text=name)
        split.label(text=value)


def _wrap(text: str, width: int) -> list[str]:
    lines, line = [], ""
    for word in text.split():
        if line and len(line) + 1 + len(word) > width:
            lines.append(line)
            line = word
        else:
            line = f"{line} {word}".strip()
    return lines + ([line] if line else [])


classes = (MOTIONKIT_PG_batch_row, MOTIONKIT_PG_batch, MOTIONKIT_OT_retarget_library, MOTIONKIT_UL_batch_report,
           MOTIONKIT_PT_retarget_batch)


def register_properties():
    bpy.types.Scene.motionkit_batch = PointerProperty(type=MOTIONKIT_PG_batch)


def unregister_properties():
    del bpy.types.Scene.motionkit_batch
