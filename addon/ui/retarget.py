"""Retargeting in the UI: the Retarget panel's settings (kept on the scene, scene.motionkit_retarget),
the bone map list and its operators (auto-map, schemes, load and save), the Retarget operator, and the
panel with its Bone Map, Controls, Options and Plant Feet sub-panels."""
import os

import bpy
from bpy.props import (BoolProperty, CollectionProperty, EnumProperty, FloatProperty, IntProperty,
                       PointerProperty, StringProperty)
from bpy_extras.io_utils import ExportHelper, ImportHelper

from . import common, contacts as contact_ui, preview
from .preview import MOTIONKIT_PG_retarget_preview
from ..blender import pose_channels
from ..core import bone_mapping, channel_carry, display_names, props, retarget_parts
from ..core.chain_modes import CHAINS
from ..core.retarget_options import BODY_MODES, RetargetOptions
from ..features import bvh, control_rigs, retarget_sources, retargeting, scene_timing


_LIMB_MODES = (("fk", "FK", "Forward kinematics: the limb's bones are keyed"),
               ("ik", "IK", "The limb's IK effector and pole are keyed (feet hold still where planted)"))


def _is_armature(self, obj):
    return obj.type == 'ARMATURE'


_AUTO = "Keep the target's posture where both rigs stand alike, match the source's direction where they stand " \
        "in different poses (a T against an A)"
_KEEP = "The target keeps its own posture (its spine's curve, its knees' bend) and moves from it as the source " \
        "moves from its own"
_MATCH = "The target's bones are turned onto the source's directions first"
_CHAIN_LABELS = {"trunk": "Trunk", "arm.L": "Left arm", "arm.R": "Right arm", "leg.L": "Left leg",
                 "leg.R": "Right leg", "fingers.L": "Left fingers", "fingers.R": "Right fingers"}
_ITEMS = {}  # Blender keeps no reference to dynamic enum items: they live here while shown


def _chain_prop(chain: str) -> str:
    return "chain_" + chain.replace(".", "_").lower()


def _chain_items(chain: str):
    """The chain's modes, Auto named after what it decided last ("(Keep)", "(Match)") so that the list says
    it without a column of its own."""
    def items(self, context):
        mode, angle = self.decided().get(chain, ("", ""))
        auto = f"({mode.capitalize()})" if mode else "Auto"
        why = f"Decided: {mode.lower()}" + (f", the limb's line {angle}\u00b0 from the source's" if angle else "")
        _ITEMS[chain] = [("AUTO", auto, f"{_AUTO}. {why}" if mode else _AUTO, 0),
                         ("KEEP", "Keep", _KEEP, 1), ("MATCH", "Match", _MATCH, 2)]
        return _ITEMS[chain]
    return items


def _chain_properties() -> dict:
    return {_chain_prop(c): EnumProperty(name=_CHAIN_LABELS[c], items=_chain_items(c), default=0,
                                         description=f"How the target's {_CHAIN_LABELS[c].lower()} stands in the "
                                                     f"reference pose")
            for c in CHAINS}


# Set while a preset ticks the rows: their updates must not turn the preset into "custom".
_TICKING = {"now": False}


def _pair_use_changed(self, context):
    settings = context.scene.motionkit_retarget
    if settings.parts != "custom" and not _TICKING["now"]:
        settings.parts = "custom"


class MOTIONKIT_PG_bone_pair(bpy.types.PropertyGroup):
    source: StringProperty(name="Source", description="Bone of the source armature (or BVH joint)")
    target: StringProperty(name="Target", description="Bone of the target armature")
    use: BoolProperty(name="Retarget", default=True, update=_pair_use_changed,
                      description="Write this bone's keys (off: the target bone keeps its own keys); the map still "
                                  "pairs it, so the bones written move as in a whole-body retarget")


# The channels the channel map renames (bone scale goes by the bone map).
NAMED_CHANNELS = ("properties", "shape_keys")


class MOTIONKIT_PG_channel_pair(bpy.types.PropertyGroup):
    source: StringProperty(name="Source Name",
                           description="A custom property or shape key of the source (by its name, e.g. smile)")
    target: StringProperty(name="Target Name",
                           description="The target's property or shape key that takes the source's values "
                                       "(e.g. mouthSmileLeft)")


_PARTS = retarget_parts.PRESETS + (("custom", "Custom", "The bones ticked in the bone map"),)


def _parts_changed(self, context):
    if self.parts != "custom":
        _tick_parts(self)


def _tick_parts(settings) -> None:
    """Each pair's Retarget as the preset says, read off the target's labelled body."""
    if settings.target is None or not settings.pairs:
        return
    rig = pose_channels.read_rig(settings.target)
    chosen = {rig.names[b] for b in retarget_parts.chosen_bones(settings.parts, rig.names, rig.parents, rig.body)}
    _TICKING["now"] = True
    try:
        for pair in settings.pairs:
            pair.use = pair.target in chosen
    finally:
        _TICKING["now"] = False


class MOTIONKIT_PG_reference_pose(bpy.types.PropertyGroup):
    """Per chain (CHAINS) the user's mode (chain_trunk, chain_arm_l, ...), and what Auto
    decided last (chains_decided: chain:MODE:angle, comma-separated)."""
    __annotations__ = {**_chain_properties(), "chains_decided": StringProperty(name="Decided")}

    def chain_modes(self) -> dict:
        """The user's chain modes ({chain: KEEP | MATCH}), the Auto ones left out."""
        return {c: getattr(self, _chain_prop(c)) for c in CHAINS
                if getattr(self, _chain_prop(c)) != "AUTO"}

    def set_chain_modes(self, modes: dict) -> None:
        for c in CHAINS:
            setattr(self, _chain_prop(c), modes.get(c, "AUTO"))

    def decided(self) -> dict:
        """{chain: (mode, angle text)} as chains_decided holds it."""
        out = {}
        for item in filter(None, self.chains_decided.split(",")):
            chain, mode, angle = item.split(":")
            out[chain] = (mode, angle)
        return out

    def record_chains(self, chains) -> None:
        self.chains_decided = ",".join(
            f"{c.chain}:{c.mode}:{'' if c.angle != c.angle else f'{c.angle:.0f}'}" for c in chains)


class MOTIONKIT_PG_retarget(bpy.types.PropertyGroup):
    source_kind: EnumProperty(name="Source", items=[
        ('ARMATURE', "Armature", "An animated armature in this file"),
        ('FILE', "File", "A BVH, FBX, GLB or glTF file, imported as the source armature when retargeting (FBX and "
                        "glTF through Blender's own importers)")], default='ARMATURE')
    source: PointerProperty(name="Source", type=bpy.types.Object, poll=_is_armature,
                            description="The animated armature whose motion is retargeted")
    source_path: StringProperty(name="File", subtype='FILE_PATH',
                                description="The BVH, FBX, GLB or glTF file to retarget")
    bvh_auto_scale: BoolProperty(name="Auto Scale", default=True,
                                 description="Stand the imported armature as tall as the target (a centimetre "
                                             "file would otherwise stand 100 times too tall)")
    bvh_scale: FloatProperty(name="Scale", default=1.0, min=1e-6, max=1e6,
                             description="Multiply the file's distances by this")
    imported_source: EnumProperty(name="Imported", items=retarget_sources.IMPORTED_SOURCES, default="hide",
                                  description="What the imported armature becomes once the target is keyed")
    target: PointerProperty(name="Target", type=bpy.types.Object, poll=_is_armature,
                            description="The armature that receives the motion as a new action")
    pairs: CollectionProperty(type=MOTIONKIT_PG_bone_pair)
    active_pair: IntProperty(name="Active Pair")
    source_match: EnumProperty(name="Source Pose", items=retargeting.SOURCE_MATCHES, default='REST',
                               description="The source's pose that matches the target's")
    match_frame: IntProperty(name="Match Frame", description="Frame of the source's match pose", default=0)
    target_match: EnumProperty(name="Target Pose", items=retargeting.TARGET_MATCHES, default='REST',
                               description="The target's pose that matches the source's")
    root_motion: EnumProperty(name="Root Motion", items=retargeting.ROOT_MOTIONS, default="scaled")
    scale_horizontal: FloatProperty(name="Stride", default=1.0, min=0.0, soft_max=2.0,
                                    description="Scale Horizontal: the travel across the floor, times this on top "
                                                "of the rigs' ratio (a character that strides wider or shorter "
                                                "than its proportions say); the height is not touched")
    root_motion_onto: EnumProperty(name="Onto", items=retargeting.ROOT_MOTION_ONTO, default="auto",
                                   description="Where the target's travel goes: its hips, its root bone or its object")
    floor_root: EnumProperty(name="Floor Root", items=retargeting.FLOOR_ROOTS, default="auto",
                             description="What a target bone on the floor above the hips (a game rig's root) does")
    root_smoothing: FloatProperty(name="Smoothing", default=0.25, min=0.0, soft_max=2.0, unit='TIME_ABSOLUTE',
                                  description="Seconds of smoothing of the extracted root motion")
    plant_feet: BoolProperty(name="Plant Feet", default=True,
                             description="Feet that stand still in the source stay planted on the target "
                                         "(contacts detected on the source, held with full-body IK, and keyed on "
                                         "the new action as 0/1 curves)")
    contacts: PointerProperty(type=contact_ui.MOTIONKIT_PG_contacts)
    floor_fit: EnumProperty(name="Stand", items=retargeting.FLOOR_FITS, default="legs",
                            description="How the target's feet are put on its own floor (its rest soles) where "
                                        "the source's stand on theirs")
    align_facing: BoolProperty(name="Align Facing", default=True,
                               description="Turn the motion by quarter turns so that each rig walks the way "
                                           "it faces")
    use_frame_range: BoolProperty(name="Frame Range", description="Retarget these source frames only")
    scene_from_clip: BoolProperty(name="From Clip", default=True,
                                  description="Set the scene's frame rate and range from the retargeted clip, so "
                                              "that it plays at the speed it was captured at and whole")
    frame_start: IntProperty(name="Start", default=1)
    frame_end: IntProperty(name="End", default=250)
    overwrite: BoolProperty(name="Overwrite",
                            description="Write into the target's own action instead of a new one")
    controls: EnumProperty(name="Key", items=retargeting.CONTROLS, default="auto",
                           description="On a control rig (Rigify's, or one a control rig map describes): key its "
                                       "controls, or the mapped bones themselves")
    arms: EnumProperty(name="Arms", items=_LIMB_MODES, default="fk", description="The arms' mode on a control rig")
    legs: EnumProperty(name="Legs", items=_LIMB_MODES, default="ik", description="The legs' mode on a control rig")
    control_map: StringProperty(name="Control Map", subtype='FILE_PATH',
                                description="A control rig map (JSON) for a rig MotionKit does not recognise; "
                                            "empty: recognised rigs only")
    keys: EnumProperty(name="Keys", items=control_rigs.KEYS, default="every",
                       description="Which frames the controls are keyed on")
    reduce: BoolProperty(name="Reduce Keys",
                         description="Afterwards, the fewest keys that stay within 0.1 degree and 1 mm, so that "
                                     "the result stays editable")

    reference_pose: PointerProperty(type=MOTIONKIT_PG_reference_pose)
    parts: EnumProperty(name="Body", items=_PARTS, default="whole", update=_parts_changed,
                        description="Which parts of the target are written; the others keep their own keys")
    into: EnumProperty(name="Into", items=retarget_parts.INTO, default="new", description="Where the keys go")
    blend: EnumProperty(name="Blend", items=retarget_parts.BLENDS, default="replace",
                        description="How the NLA track blends over the motion below it")
    influence: FloatProperty(name="Influence", default=1.0, min=0.0, max=1.0, subtype='FACTOR',
                             description="How much of the NLA track shows")
    channels: EnumProperty(name="Carry", items=channel_carry.CHANNELS, options={'ENUM_FLAG'},
                           default=set(channel_carry.IDS),
                           description="What else is carried, by name, where the target has it (the rest is "
                                       "reported)")
    channel_pairs: CollectionProperty(type=MOTIONKIT_PG_channel_pair)
    active_channel_pair: IntProperty(name="Active Name Pair")
    prop_space: EnumProperty(name="Props", items=props.SPACES, default="bone",
                             description="How a mapped bone that is no body part (a prop or weapon bone such as "
                                         "weapon_r) moves on the target")
    two_hands: BoolProperty(name="Two Hands", default=True,
                            description="A prop under one hand that the source's other hand holds (a rifle): the "
                                        "target's other hand stays where the source's holds it, relative to the "
                                        "prop and scaled, whatever the arms' lengths")
    body: EnumProperty(name="Body", items=BODY_MODES, default="auto",
                       description="Keep the target's forearms and hands out of its own body where it has a skinned "
                                   "mesh")
    body_strength: FloatProperty(name="Strength", default=1.0, min=0.0, max=1.0, subtype='FACTOR',
                                 description="How much of the way out of the body each arm is moved")
    body_touches: BoolProperty(name="Touches", default=True,
                               description="Where the source's hand touches its own body (both characters skinned), "
                                           "the target's hand is brought onto its own")
    preview: PointerProperty(type=MOTIONKIT_PG_retarget_preview)

    def bone_map(self) -> list[tuple[str, str]]:
        return [(p.source, p.target) for p in self.pairs if p.source and p.target]

    def retarget_options(self, named: bool = True) -> RetargetOptions:
        """The panel's retarget options, as motionkit.retarget takes them. The panel leaves no floor height
        to set (each rig's rest soles) and plants feet where both rigs have them, or never. named=False
        leaves the channel map out (what the reference pose reads does not depend on it)."""
        return RetargetOptions(
            root=self.root_motion, scale_horizontal=self.scale_horizontal, source_match=self.source_match,
            match_frame=self.match_frame if self.source_match == 'FRAME' else None,
            target_match=self.target_match, align_facing=self.align_facing,
            floor_root=self.floor_root if self.root_motion_onto == "auto" else "auto",
            root_motion_onto=self.root_motion_onto, root_smoothing=self.root_smoothing,
            plant_feet=None if self.plant_feet else False, contact_settings=contact_ui.settings(self.contacts),
            floor_fit=self.floor_fit, chain_modes=self.reference_pose.chain_modes() or None,
            channels=tuple(c for c in channel_carry.IDS if c in self.channels),
            channel_map=self.channel_map() if named else None, prop_space=self.prop_space, two_hands=self.two_hands,
            body=self.body, body_strength=self.body_strength, body_touches=self.body_touches, **self._written())

    def control_keywords(self) -> dict:
        """The panel's control rig choices (controls, limbs, control_map, keys, reduce) as retarget_clip and
        the batch take them."""
        chosen = {"controls": self.controls, "keys": self.keys, "reduce": self.reduce,
                  "control_map": bpy.path.abspath(self.control_map) if self.control_map else None}
        if self.controls == "auto":
            chosen["limbs"] = {"arm": self.arms, "leg": self.legs}
        return chosen

    def channel_map(self) -> dict | None:
        """{source name: target name} from the channel map's rows, None when it has none or no channel it
        renames is carried. A row with neither name (just added) is passed over; a row with one name, or a
        source name given twice, is a ValueError naming the row."""
        if not set(NAMED_CHANNELS) & set(self.channels):
            return None
        out = {}
        for row, pair in enumerate(self.channel_pairs, 1):
            if not pair.source and not pair.target:
                continue
            if not (pair.source and pair.target):
                raise ValueError(f"Channel map, row {row}: give both a source and a target name "
                                 f"(has {pair.source or pair.target!r} only)")
            if pair.source in out:
                raise ValueError(f"Channel map, row {row}: {pair.source!r} is mapped twice (to "
                                 f"{out[pair.source]!r} above)")
            out[pair.source] = pair.target
        return out or None

    def _written(self) -> dict:
        """What the panel writes and where: the preset's parts, or the ticked rows' target bones."""
        chosen = {"into": self.into, "blend": self.blend, "influence": self.influence}
        if self.parts != "custom":
            return {**chosen, "parts": self.parts}
        bones = tuple(p.target for p in self.pairs if p.use and p.source and p.target)
        return {**chosen, "bones": bones or None}

    def set_bone_map(self, pairs) -> None:
        self.pairs.clear()
        for source, target in pairs:
            item = self.pairs.add()
            item.source, item.target = source, target
        self.active_pair = 0
        if self.parts != "custom":
            _tick_parts(self)


def _settings(context):
    return context.scene.motionkit_retarget


def _source_ready(settings) -> str:
    """Why the source cannot be used yet, or ''."""
    if settings.source_kind == 'FILE':
        path = bpy.path.abspath(settings.source_path)
        return "" if path and os.path.isfile(path) else "Pick a BVH file"
    return "" if settings.source is not None else "Pick a source armature"


def _source_rig(settings):
    if settings.source_kind == 'FILE':
        return bvh.file_mapping_rig(bpy.path.abspath(settings.source_path))
    return pose_channels.armature_mapping_rig(settings.source, upright=True)


def _poll_rigs(cls, context) -> bool:
    settings = _settings(context)
    why = _source_ready(settings) or ("" if settings.target is not None else "Pick a target armature")
    if why:
        cls.poll_message_set(why)
        return False
    return True


def _fill_map(operator, context, pairs_of) -> set:
    """Put pairs_of(settings) into the bone map, reporting how many."""
    settings = _settings(context)

    def fill(progress):
        pairs = pairs_of(settings)
        settings.set_bone_map(pairs)
        return pairs

    return common.run(operator, context, fill, lambda pairs: f"Mapped {len(pairs)} bones")


class MOTIONKIT_OT_retarget(bpy.types.Operator):
    """Retarget the source's motion onto the target armature as a new action (MotionKit)"""
    bl_idname = "motionkit.retarget"
    bl_label = "Retarget"
    bl_options = {'REGISTER', 'UNDO'}

    @classmethod
    def poll(cls, context):
        if _settings(context).preview.on:
            cls.poll_message_set("Apply or cancel the preview first")
            return False
        return common.poll_native(cls) and _poll_rigs(cls, context)

    def execute(self, context):
        return run_retarget(self, context)


def run_retarget(self, context) -> set:
    """The Retarget button's work for an operator (self): the panel's settings retargeted and keyed."""
    settings = _settings(context)
    source = bpy.path.abspath(settings.source_path) if settings.source_kind == 'FILE' else settings.source
    frame_range = (settings.frame_start, settings.frame_end) if settings.use_frame_range else None

    bvh_options = ({"bvh_scale": "auto" if settings.bvh_auto_scale else settings.bvh_scale,
                    "imported_source": settings.imported_source} if settings.source_kind == 'FILE' else {})

    controls = settings.control_keywords()

    def work(progress):
        progress(0, 4)
        made = retargeting.retarget_clip(
            source, settings.target, settings.bone_map() or None, frame_range, settings.retarget_options(),
            overwrite=settings.overwrite, progress=progress, **controls, **bvh_options)
        action = made.action
        timing = scene_timing.from_clip(context.scene, action) if settings.scene_from_clip else None
        not_carried = channel_carry.summary(made.channels_left_out)
        settings.reference_pose.record_chains(made.chains)  # as the retarget decided them
        # What the automatic map left out, as the retarget made it (no rig read again to say so).
        left_out = made.map_report.message() if made.map_report is not None and settings.source_kind == 'ARMATURE' \
            else ""
        body = made.body.message() if made.body is not None and made.body.state != "off" else ""
        return action, timing, left_out, not_carried, body

    def done(result):
        action, timing, left_out, not_carried, body = result
        if body:
            self.report({'INFO'}, body)
        if left_out:
            self.report({'WARNING'}, f"Auto-mapped; {left_out}")
        if not_carried:  # the target has no bone, property or shape key for them
            self.report({'WARNING'}, not_carried)
        played = f"; the scene plays it at {timing[0]:g} fps, frames {timing[1]}-{timing[2]}" if timing else ""
        decided = _decided_text(settings)
        return f"Retargeted onto '{settings.target.name}' as action '{action.name}'{played}" + (
            f". {decided}" if decided else "")

    return common.run(self, context, work, done)


class MOTIONKIT_OT_retarget_preview_apply(bpy.types.Operator):
    """Key the previewed retarget, as Retarget does (MotionKit)"""
    bl_idname = "motionkit.retarget_preview_apply"
    bl_label = "Apply"
    bl_options = {'REGISTER', 'UNDO'}

    @classmethod
    def poll(cls, context):
        return context.scene.motionkit_retarget.preview.on

    def execute(self, context):
        preview.stop(context.scene.motionkit_retarget)
        return run_retarget(self, context)


class MOTIONKIT_OT_bone_map_auto(bpy.types.Operator):
    """Fill the bone map from the bones' names and, where names say nothing, the skeletons (MotionKit)"""
    bl_idname = "motionkit.bone_map_auto"
    bl_label = "Auto-map"
    bl_options = {'REGISTER', 'UNDO'}

    @classmethod
    def poll(cls, context):
        return _poll_rigs(cls, context)

    def execute(self, context):
        left_out = []

        def auto_map(settings):
            report = bone_mapping.auto_map_report(_source_rig(settings),
                                                  pose_channels.armature_mapping_rig(settings.target, upright=True))
            _decide_chains(settings, report.pairs)
            left_out.append(report.message())
            return report.pairs

        done = _fill_map(self, context, auto_map)
        if done == {'FINISHED'} and left_out and left_out[0]:
            self.report({'WARNING'}, f"Mapped {len(_settings(context).pairs)} bones; {left_out[0]}")
        return done


def _decide_chains(settings, pairs) -> None:
    """What Auto decides per chain, for the panel, where the source is an armature with an action (a file is
    read only when retargeting)."""
    chains = settings.reference_pose
    chains.chains_decided = ""
    source = settings.source if settings.source_kind == 'ARMATURE' else None
    if source is None or source.animation_data is None or source.animation_data.action is None:
        return
    chains.record_chains(retargeting.reference_chains(source, settings.target, pairs,
                                                       settings.retarget_options(named=False)))


class MOTIONKIT_OT_reference_pose(bpy.types.Operator):
    """Decide again, from the two rigs' match poses, which chains keep the target's posture (MotionKit)"""
    bl_idname = "motionkit.reference_pose"
    bl_label = "Decide Reference Pose"
    bl_options = {'REGISTER', 'UNDO'}

    @classmethod
    def poll(cls, context):
        if not (common.poll_native(cls) and _poll_rigs(cls, context)):
            return False
        if _settings(context).source_kind != 'ARMATURE':
            cls.poll_message_set("A file source is decided when retargeting")
            return False
        return True

    def execute(self, context):
        settings = _settings(context)
        return common.run(self, context, lambda progress: _decide_chains(settings, settings.bone_map() or None),
                          lambda _: _decided_text(settings))


def _decided_text(settings) -> str:
    decided = settings.reference_pose.decided().items()
    return "Reference pose: " + ", ".join(f"{_CHAIN_LABELS[c]} {m.lower()}" for c, (m, _) in decided) if decided \
        else ""



def _scheme_items(self, context):
    return [(key, scheme.get("label", key), "") for key, scheme in sorted(bone_mapping.schemes().items())]


class MOTIONKIT_OT_bone_map_scheme(bpy.types.Operator):
    """Fill the bone map from two naming schemes MotionKit ships (Mixamo, Rigify, CMU, GAMES-105, Unreal)"""
    bl_idname = "motionkit.bone_map_scheme"
    bl_label = "Map by Schemes"
    bl_options = {'REGISTER', 'UNDO'}

    source_scheme: EnumProperty(name="Source Scheme", items=_scheme_items)
    target_scheme: EnumProperty(name="Target Scheme", items=_scheme_items)

    @classmethod
    def poll(cls, context):
        return _poll_rigs(cls, context)

    def invoke(self, context, event):
        # Wide enough for the schemes' names ("Bandai Namco Research Motion Dataset").
        return context.window_manager.invoke_props_dialog(self, width=480)

    def execute(self, context):
        return _fill_map(self, context, lambda settings: bone_mapping.map_from_presets(
            _source_rig(settings), self.source_scheme, pose_channels.armature_mapping_rig(settings.target, upright=True), self.target_scheme))


class MOTIONKIT_OT_bone_map_save(bpy.types.Operator, ExportHelper):
    """Save the bone map as a JSON preset"""
    bl_idname = "motionkit.bone_map_save"
    bl_label = "Save Bone Map"

    filename_ext = ".json"
    filter_glob: StringProperty(default="*.json", options={'HIDDEN'})

    def execute(self, context):
        settings = _settings(context)
        return common.run(self, context, lambda progress: bone_mapping.save_map(
            self.filepath, settings.bone_map(), chains=settings.reference_pose.chain_modes()), lambda _: "")


class MOTIONKIT_OT_bone_map_load(bpy.types.Operator, ImportHelper):
    """Load a bone map saved as a JSON preset"""
    bl_idname = "motionkit.bone_map_load"
    bl_label = "Load Bone Map"
    bl_options = {'REGISTER', 'UNDO'}

    filename_ext = ".json"
    filter_glob: StringProperty(default="*.json", options={'HIDDEN'})

    def execute(self, context):
        def load(settings):
            pairs, chains = bone_mapping.load_map(self.filepath), bone_mapping.load_chains(self.filepath)
            settings.reference_pose.set_chain_modes(chains)
            return pairs

        return _fill_map(self, context, load)


# The most of a row the target's names may take, so that the source's still say something.
TARGET_SHARE_MAX = 0.6
# How the bone map's list shows its names, worked out once per draw of the panel for the list's rows: the
# prefixes each side's names share ("mixamorig:"), the source column's share of a row, a row's room in pixels.
_SHOWN = {"prefixes": ("", ""), "split": 0.5, "row_width": 200.0}


def _header(prefix: str, side: str) -> str:
    return f"{prefix}*" if prefix else side


def _plan_bone_map_list(context, settings, scrolls: bool) -> None:
    """The target's names whole where a row holds them (the rig being animated is the one the user knows by
    name), the source's in what is left; either cut in the middle when too long."""
    scale = common.set_interface_font(context)
    prefixes = tuple(display_names.shared_prefix(getattr(p, side) for p in settings.pairs)
                     for side in ("source", "target"))
    row_width = context.region.width - (common.LIST_MARGIN_PX + common.SCROLL_BAR_PX * scrolls) * scale
    padding = common.LABEL_PADDING_PX * scale
    target_width = max([common.text_width(display_names.strip(p.target, prefixes[1])) for p in settings.pairs]
                       + [common.text_width(_header(prefixes[1], "Target"))]) + padding
    source_header_width = common.text_width(_header(prefixes[0], "Source")) + padding
    row_width = max(row_width, 1.0)
    split = max(1.0 - min(target_width / row_width, TARGET_SHARE_MAX), source_header_width / row_width)
    _SHOWN.update(prefixes=prefixes, split=split, row_width=row_width)


class MOTIONKIT_UL_bone_map(bpy.types.UIList):
    """One row per source -> target pair, as names: the list is for reading and picking a row; the picked
    pair is edited below it, where its fields have the panel's whole width."""

    def draw_item(self, context, layout, data, item, icon, active_data, active_propname, index=0):
        # Blender clips a long label at its end, and a hand's rows would all read "LeftHand...": cut in the
        # middle instead, to what a column of the list holds, measured in the interface's own font.
        scale = common.set_interface_font(context)
        split = layout.split(factor=_SHOWN["split"])
        layout.active = item.use  # a row not retargeted is drawn dim
        for name, prefix, share in ((item.source, _SHOWN["prefixes"][0], _SHOWN["split"]),
                                    (item.target, _SHOWN["prefixes"][1], 1.0 - _SHOWN["split"])):
            shown = display_names.strip(name, prefix)
            room = _SHOWN["row_width"] * share - common.LABEL_PADDING_PX * scale
            split.label(text=display_names.fit_width(shown, room, common.text_width) if shown else "(none)")


class MOTIONKIT_UL_channel_map(bpy.types.UIList):
    """One row per name pair: the source's property or shape key, and the target's that takes its values."""

    def draw_item(self, context, layout, data, item, icon, active_data, active_propname, index=0):
        split = layout.split(factor=0.5, align=True)
        split.prop(item, "source", text="")
        split.prop(item, "target", text="")


def _poll_channel_map(cls, context) -> bool:
    if not set(NAMED_CHANNELS) & set(_settings(context).channels):
        cls.poll_message_set("Carry Properties or Shape Keys first: the channel map renames those")
        return False
    return True


class MOTIONKIT_OT_channel_map_add(bpy.types.Operator):
    """Add a pair of names to the channel map: a source's custom property or shape key carried onto the
    target's of another name"""
    bl_idname = "motionkit.channel_map_add"
    bl_label = "Add Name Pair"
    bl_options = {'REGISTER', 'UNDO'}

    @classmethod
    def poll(cls, context):
        return _poll_channel_map(cls, context)

    def execute(self, context):
        settings = _settings(context)
        settings.channel_pairs.add()
        settings.active_channel_pair = len(settings.channel_pairs) - 1
        return {'FINISHED'}


class MOTIONKIT_OT_channel_map_remove(bpy.types.Operator):
    """Remove the selected pair of names from the channel map"""
    bl_idname = "motionkit.channel_map_remove"
    bl_label = "Remove Name Pair"
    bl_options = {'REGISTER', 'UNDO'}

    @classmethod
    def poll(cls, context):
        settings = _settings(context)
        if not _poll_channel_map(cls, context):
            return False
        if not 0 <= settings.active_channel_pair < len(settings.channel_pairs):
            cls.poll_message_set("The channel map is empty" if not settings.channel_pairs else "Select a row")
            return False
        return True

    def execute(self, context):
        settings = _settings(context)
        settings.channel_pairs.remove(settings.active_channel_pair)
        settings.active_channel_pair = min(settings.active_channel_pair, len(settings.channel_pairs) - 1)
        return {'FINISHED'}


def _draw_bone_field(layout, holder, prop, rig, label):
    """A bone name over the panel's whole width, picked from the rig's bones when there is one."""
    layout.label(text=label)
    if rig is not None:
        layout.prop_search(holder, prop, rig.data, "bones", text="")
    else:
        layout.prop(holder, prop, text="")


def _labelled(layout, text):
    """A short label, then the rest of the row for a field."""
    split = layout.split(factor=0.3)
    split.alignment = 'RIGHT'
    split.label(text=text)
    return split


class MOTIONKIT_PT_retarget(common.SidebarPanel, bpy.types.Panel):
    bl_label = "Retarget"

    def draw(self, context):
        settings = context.scene.motionkit_retarget
        layout = self.layout
        layout.row().prop(settings, "source_kind", expand=True)
        # Names of rigs and files get the room a split's 40 % label column would take.
        col = layout.column(align=True)
        if settings.source_kind == 'FILE':
            _labelled(col, "File").prop(settings, "source_path", text="")
        else:
            _labelled(col, "Source").prop(settings, "source", text="")
        _labelled(col, "Target").prop(settings, "target", text="")
        if settings.source_kind == 'FILE':
            col = common.split_layout(layout.column())
            col.prop(settings, "bvh_auto_scale")
            if not settings.bvh_auto_scale:
                col.prop(settings, "bvh_scale")
            col.prop(settings, "imported_source")
        layout.operator("motionkit.retarget", icon='ARMATURE_DATA')
        _draw_preview(layout, settings.preview)


def _draw_preview(layout, state) -> None:
    """Preview, or while it plays Apply and Cancel, and what the last update took (or why it failed)."""
    row = layout.row(align=True)
    if not state.on:
        row.operator("motionkit.retarget_preview", icon='HIDE_OFF')
        return
    row.operator("motionkit.retarget_preview_apply", icon='CHECKMARK')
    row.operator("motionkit.retarget_preview_cancel", icon='X')
    if state.message:
        layout.label(text=state.message, icon='ERROR')
    else:
        layout.label(text=f"Updated in {state.seconds:.2f} seconds", icon='TIME')


class RetargetSubPanel(common.SidebarPanel):
    """A panel under the Retarget panel (Blender names each panel after its class)."""
    bl_parent_id = "MOTIONKIT_PT_retarget"


class MOTIONKIT_PT_retarget_map(RetargetSubPanel, bpy.types.Panel):
    """The bone map: names side by side, the shared prefixes said once, the picked pair's fields below."""
    bl_label = "Bone Map"

    def draw(self, context):
        settings = context.scene.motionkit_retarget
        layout = self.layout
        rows = min(max(len(settings.pairs), 6), 40)
        _plan_bone_map_list(context, settings, scrolls=len(settings.pairs) > rows)
        header = layout.split(factor=_SHOWN["split"])
        for prefix, side in zip(_SHOWN["prefixes"], ("Source", "Target")):
            header.label(text=_header(prefix, side))
        # The list takes the panel's whole width, its buttons under it, and shows a whole body's map without a
        # scroll bar: each takes room from the names.
        layout.template_list("MOTIONKIT_UL_bone_map", "", settings, "pairs", settings, "active_pair", rows=rows)
        row = layout.row()
        sub = row.row(align=True)
        common.draw_list_buttons(sub, BONE_MAP.name)
        sub = row.row(align=True)
        sub.operator("motionkit.bone_map_load", text="Load", icon='FILEBROWSER')
        sub.operator("motionkit.bone_map_save", text="Save", icon='FILE_TICK')
        row = layout.row(align=True)
        row.operator("motionkit.bone_map_auto", text="Auto-map", icon='AUTO')
        row.operator("motionkit.bone_map_scheme", text="Schemes", icon='PRESET')
        _labelled(layout, "Body").prop(settings, "parts", text="")
        if not settings.pairs:
            layout.label(text="Empty: auto-mapped", icon='INFO')
        elif 0 <= settings.active_pair < len(settings.pairs):
            item = settings.pairs[settings.active_pair]
            col = layout.column(align=True)
            _draw_bone_field(col, item, "source", settings.source if settings.source_kind == 'ARMATURE' else None,
                             "Source Bone")
            _draw_bone_field(col, item, "target", settings.target, "Target Bone")
            col.prop(item, "use")
        _draw_reference_pose(layout.box(), settings)


def _draw_reference_pose(box, settings) -> None:
    """Per chain the user's mode, Auto showing what it decided ("(Match)"), a row each: two sides in one row
    leave each menu too narrow for that at the default sidebar width."""
    row = box.row()
    row.label(text="Reference Pose")
    row.operator("motionkit.reference_pose", text="", icon='FILE_REFRESH')
    for chain in CHAINS:
        split = box.split(factor=0.5)  # "Right Fingers" whole at the default sidebar width
        split.label(text=_CHAIN_LABELS[chain].title())
        split.prop(settings.reference_pose, _chain_prop(chain), text="")


class MOTIONKIT_PT_retarget_controls(RetargetSubPanel, bpy.types.Panel):
    """What the target is (a control rig MotionKit recognises, or bones), and how its limbs are keyed."""
    bl_label = "Controls"

    def draw(self, context):
        settings = context.scene.motionkit_retarget
        layout = self.layout
        kind = control_rigs.describe(settings.target, settings.control_map) if settings.target else "No target"
        layout.label(text=kind, icon='ARMATURE_DATA')
        layout.row().prop(settings, "controls", expand=True)
        col = common.split_layout(layout.column())
        col.active = settings.controls == "auto" and kind.endswith("(controls)")
        col.row().prop(settings, "arms", expand=True)
        col.row().prop(settings, "legs", expand=True)
        col = common.split_layout(layout.column())
        col.active = settings.controls != "none"
        col.prop(settings, "keys")
        col.prop(settings, "reduce")
        layout.label(text="Map (other rigs)")
        layout.prop(settings, "control_map", text="")


class MOTIONKIT_PT_retarget_options(RetargetSubPanel, bpy.types.Panel):
    bl_label = "Options"

    def draw(self, context):
        settings = context.scene.motionkit_retarget
        layout = common.split_layout(self.layout)
        layout.label(text="Match Poses")
        col = layout.column()
        col.prop(settings, "source_match", text="Source")
        if settings.source_match == 'FRAME':
            col.prop(settings, "match_frame")
        col.prop(settings, "target_match", text="Target")
        col = layout.column()
        col.prop(settings, "root_motion")
        if settings.root_motion in ("scaled", "offset"):
            col.prop(settings, "scale_horizontal")
        col.prop(settings, "root_motion_onto")
        if settings.root_motion_onto == "auto":
            col.prop(settings, "floor_root")
        if settings.floor_root == "extract" or settings.root_motion_onto in ("root", "object"):
            col.prop(settings, "root_smoothing")
        common.draw_groups(layout, settings, (("Feet", ("floor_fit",)), ("Motion", ("align_facing",))))
        common.draw_frame_range(layout, settings, "use_frame_range", "Source")
        common.draw_groups(layout, settings, (("Scene", ("scene_from_clip",)),))
        col = layout.column()
        col.prop(settings, "into")
        if settings.into == "nla":
            col.prop(settings, "blend")
            col.prop(settings, "influence")
        elif settings.into == "new":
            col.prop(settings, "overwrite")
        col = layout.column()
        col.prop(settings, "prop_space")
        col.prop(settings, "two_hands")
        col.prop(settings, "body", text="Body Mesh")
        row = col.row()
        row.active = settings.body != "off"
        row.prop(settings, "body_strength")
        row = col.row()
        row.active = settings.body != "off"
        row.prop(settings, "body_touches")
        _draw_carry(self.layout, settings)


def _draw_carry(layout, settings) -> None:
    """The channels carried, a toggle a row across the panel (side by side, or beside labels, their names are
    cut); under them, while one that goes by name is on, the channel map: source and target names side by
    side over the panel's width, its buttons under it."""
    col = layout.column(align=True)
    col.use_property_split = False
    col.label(text="Carry")
    for identifier, _, _ in channel_carry.CHANNELS:
        col.prop_enum(settings, "channels", identifier)
    if not set(NAMED_CHANNELS) & set(settings.channels):
        return
    layout.label(text="Channel Map")
    header = layout.split(factor=0.5)
    header.label(text="Source Name")
    header.label(text="Target Name")
    layout.template_list("MOTIONKIT_UL_channel_map", "", settings, "channel_pairs", settings, "active_channel_pair",
                         rows=min(max(len(settings.channel_pairs), 2), 8))
    row = layout.row(align=True)
    row.operator(MOTIONKIT_OT_channel_map_add.bl_idname, text="", icon='ADD')
    row.operator(MOTIONKIT_OT_channel_map_remove.bl_idname, text="", icon='REMOVE')


class MOTIONKIT_PT_retarget_feet(RetargetSubPanel, bpy.types.Panel):
    """Planted feet: contacts detected on the source and held on the target; their thresholds."""
    bl_label = "Plant Feet"
    bl_options = {'DEFAULT_CLOSED'}

    def draw_header(self, context):
        self.layout.prop(context.scene.motionkit_retarget, "plant_feet", text="")

    def draw(self, context):
        settings = context.scene.motionkit_retarget
        layout = common.split_layout(self.layout)
        layout.active = settings.plant_feet
        contact_ui.draw(layout, settings.contacts)


class MOTIONKIT_PT_retarget_feet_motion(common.SidebarPanel, bpy.types.Panel):
    """Which contacts are held still: not those that slide, pivot about the other point or swivel."""
    bl_label = "Slides and Pivots"
    bl_parent_id = "MOTIONKIT_PT_retarget_feet"
    bl_options = {'DEFAULT_CLOSED'}

    def draw(self, context):
        settings = context.scene.motionkit_retarget
        layout = common.split_layout(self.layout)
        layout.active = settings.plant_feet
        contact_ui.draw(layout, settings.contacts, contact_ui.MOTION_FIELDS)


BONE_MAP = common.editable_list(common.EditableList(
    "bone_map", "pair", lambda context: context.scene.motionkit_retarget, "pairs", "active_pair", "No scene"))

classes = (MOTIONKIT_PG_bone_pair, MOTIONKIT_PG_channel_pair, MOTIONKIT_PG_reference_pose,
           MOTIONKIT_PG_retarget_preview, MOTIONKIT_PG_retarget, MOTIONKIT_OT_retarget,
           MOTIONKIT_OT_retarget_preview_apply, MOTIONKIT_OT_bone_map_auto, MOTIONKIT_OT_reference_pose,
           MOTIONKIT_OT_bone_map_scheme, MOTIONKIT_OT_bone_map_save,
           MOTIONKIT_OT_bone_map_load, MOTIONKIT_UL_bone_map, MOTIONKIT_UL_channel_map, MOTIONKIT_OT_channel_map_add,
           MOTIONKIT_OT_channel_map_remove, MOTIONKIT_PT_retarget, MOTIONKIT_PT_retarget_map,
           MOTIONKIT_PT_retarget_controls, MOTIONKIT_PT_retarget_options, MOTIONKIT_PT_retarget_feet,
           MOTIONKIT_PT_retarget_feet_motion)


def register_properties():
    bpy.types.Scene.motionkit_retarget = PointerProperty(type=MOTIONKIT_PG_retarget)


def unregister_properties():
    del bpy.types.Scene.motionkit_retarget
