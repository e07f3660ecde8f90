"""Every MotionKit surface drawn in a real window, read back from its pixels (run by test_ui.py):

    blender --factory-startup --enable-event-simulate --python panels.py -- ZIP WALK60 OUT_DIR

The sidebar's MotionKit tab at its default width in object and pose mode, each panel expanded (closed
sub-panels opened by clicking their headers where the screen shows them); the active effector picked by a
click on its row; the Live toggle clicked; each operator's dialog and redo panel; the BVH import and export
file browsers; the File > Import menu and the Graph Editor's and Dope Sheet's Key menus; the Controls
sub-panel with a Rigify rig as the target. Each picture is
saved in OUT_DIR and what is read in it is reported (`UI <key> <json>`) for test_ui.py to judge.
"""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bpy  # noqa: E402
import numpy as np  # noqa: E402

import harness  # noqa: E402
import scene  # noqa: E402

zip_path, walk60, out = sys.argv[sys.argv.index("--") + 1:]
mk = harness.start(zip_path)
watch = harness.watch_category("MotionKit")


def shot(name):
    return os.path.join(out, name + ".png")


def read_sidebar(name, view, rows=None):
    """Reads the sidebar as drawn now (after harness.redrawn), or the rows (bottom, top) of it only, and
    reports it under name."""
    side = harness.region(view, 'UI')
    box = None if rows is None else (side.x, rows[0], side.width, rows[1] - rows[0])
    words, blank = harness.read_region(shot(name), side, box=box)
    harness.report(f"{name}.words", harness.plain(words))
    harness.report(f"{name}.blank", blank)
    return words


def read_rows_again(name, view, words, below, above):
    """A second reading, row by row at another size, of the sidebar's rows between the labels below and
    above (as read in words), from the picture just read: tesseract misreads a name in a list's active row
    (5.2 outlines it, "eyeBlink" read "eve Htnk") and reads it alone. Reported as name's words-again."""
    top, bottom = harness.find_words(words, below), harness.find_words(words, above)
    assert top and bottom, f"no '{below}' or '{above}' in {name}"
    side = harness.region(view, 'UI')
    pixels = harness.load_png(shot(name + "-window"))
    heights = sorted(w["y"] for w in words if bottom[0]["y"] + 10 < w["y"] < top[0]["y"] - 10)
    rows = []  # the words of a row lie within a few pixels of each other's height; a row is 20 px or more
    for y in heights:
        if rows and y - rows[-1][0] < 8:
            rows[-1].append(y)
        else:
            rows.append([y])
    again = []
    for n, row in enumerate(rows):
        box = (side.x, int(np.median(row)) - 12, side.width, 24)
        # Each reading numbers its blocks from 1: kept apart, so that two readings' words never join a label.
        again += [dict(w, block=1000 * n + w["block"]) for w in harness.ocr(harness.crop(pixels, box), box, scale=2)]
    harness.report(f"{name}.words-again", harness.plain(again))


def open_closed_panels(view, name, headers):
    """A scenario step (`yield from`): reads the sidebar once it stands still, clicks the header of each
    closed sub-panel where it shows (the lowest first: a panel opening slides only those below it down),
    then reads it again once it stands still until a label inside each is on screen; reports the last
    reading under name and returns its words. headers: (header, a label inside)."""
    def side():
        return harness.region(view, 'UI')

    words, blank = yield from harness.read_still(shot(name), side())
    closed = [(header, inside) for header, inside in headers if not harness.find_words(words, inside)]
    if closed:
        found = []
        for header, _ in closed:
            label = harness.find_words(words, header)
            assert label, f"no '{header}' header on screen"
            found.append(label[0])
        for word in sorted(found, key=lambda w: w["y"]):  # y up: the lowest first
            yield from harness.click(word["x"], word["y"])
        words, blank = yield from harness.read_until(
            shot(name), side, lambda ws: all(harness.find_words(ws, inside) for _, inside in headers),
            f"{[h for h, _ in closed]} to open", timeout=10.0)
    harness.report(f"{name}.words", harness.plain(words))
    harness.report(f"{name}.blank", blank)
    return words


def popup_words(name, before, win=None):
    """A scenario step (`yield from`): waits for the popup, returns the words of what it added to the window
    (the box where the pixels changed since `before`) and the box."""
    after, box = yield from harness.popup_shown(before, shot(name + "-window"), win)
    top, left, bottom, right = box
    part = after[top:bottom, left:right]
    harness.save_png(part, shot(name))
    height = after.shape[0]
    words = harness.ocr(part, (left, height - bottom, right - left, bottom - top))
    harness.report(f"{name}.words", harness.plain(words))
    # A second reading at another size: tesseract now and then drops a word of a small popup (4.3 underlines
    # menu accelerators, and the R underlined in a Key menu's "Resample" was lost at 3x, read at 2x).
    again = harness.ocr(part, (left, height - bottom, right - left, bottom - top), scale=2)
    harness.report(f"{name}.words-again", harness.plain(again))
    harness.report(f"{name}.blank", harness.not_blank(part))
    return words, box


def redo_panel_open(view, name, title, last):
    """A scenario step (`yield from`): waits for the redo panel's folded header (title read in it), clicks
    it open, waits until its last option (last) is read, and reports what it shows. Blender 3.4 sizes the
    region for the open panel from the start, so only the pixels say when it has opened."""
    def hud():
        return next((r for r in view.regions if r.type == 'HUD' and r.width > 1 and r.height > 1), None)

    yield from harness.read_until(shot(name), hud, lambda ws: harness.find_words(ws, title),
                                  f"{name}: the redo panel's header", timeout=8.0)
    region_ = hud()
    yield from harness.click(region_.x + region_.width // 2, region_.y + region_.height // 2)
    words, blank = yield from harness.read_until(shot(name), hud, lambda ws: harness.find_words(ws, last),
                                                 f"{name}: '{last}' in the open redo panel", timeout=8.0,
                                                 required=False)
    harness.report(f"{name}.words", harness.plain(words))
    harness.report(f"{name}.blank", blank)


CHANNEL_PAIRS = (("smile", "grin"), ("blink", "eyeBlink"))
UNDO_FRAMES = (1, 45, 90)


def target_state(name) -> dict:
    """The target as Blender evaluates it: its action's name, every F-curve's keys and handles (bytes), and
    every bone's matrix and the object's on UNDO_FRAMES (the scene's frame put back)."""
    obj = bpy.data.objects[name]
    action = obj.animation_data.action if obj.animation_data else None
    keys = {}
    for fc in mk.animdata.fcurves(action, obj) if action else ():
        points = fc.keyframe_points
        values = []
        for field in ("co", "handle_left", "handle_right"):
            array = np.empty(2 * len(points), dtype=np.float32)
            points.foreach_get(field, array)
            values.append(array.tobytes())
        keys[(fc.data_path, fc.array_index)] = tuple(values) + (tuple(p.interpolation for p in points),)
    scene = bpy.context.scene
    frame = scene.frame_current
    pose = []
    for f in UNDO_FRAMES:
        scene.frame_set(f)
        pose.append([np.array(obj.matrix_world)] + [np.array(b.matrix) for b in obj.pose.bones])
    scene.frame_set(frame)
    return {"action": action.name if action else None, "keys": keys, "pose": np.array(pose),
            "actions": sorted(a.name for a in bpy.data.actions)}


def action_name(name):
    obj = bpy.data.objects.get(name)
    action = obj.animation_data.action if obj is not None and obj.animation_data else None
    return action.name if action else None


def compare(key, state, reference) -> None:
    """Reports how state differs from reference: action, keys (bit for bit), pose (largest difference)."""
    harness.report(f"{key}.action", [state["action"], reference["action"]])
    harness.report(f"{key}.keys_same", state["keys"] == reference["keys"] and len(state["keys"]) > 0)
    harness.report(f"{key}.pose", float(np.abs(state["pose"] - reference["pose"]).max()))
    harness.report(f"{key}.actions", [state["actions"], reference["actions"]])


def preview_apply_undo(view, name):
    """A scenario step (`yield from`): Preview, Apply, then ctrl+Z pressed in the window and ctrl+shift+Z,
    the target read after each as Blender evaluates it. The undo step before Preview is pushed here as the
    last click on a panel's field pushes one (the scenario sets the fields from Python, which pushes none)."""
    with harness.override(area_=view):
        bpy.ops.ed.undo_push(message="Retarget panel")
    before = target_state(name)
    with harness.override(area_=view):
        harness.report("undo_apply.preview", sorted(bpy.ops.motionkit.retarget_preview('EXEC_DEFAULT')))
    harness.report("undo_apply.previewed", bpy.data.objects[name].animation_data.action.name)
    with harness.override(area_=view):
        harness.report("undo_apply.apply", sorted(bpy.ops.motionkit.retarget_preview_apply('EXEC_DEFAULT', True)))
    applied = target_state(name)
    compare("undo_apply.applied", applied, before)
    x, y = view.x + view.width // 2, view.y + view.height // 2
    for key, shift, reference in (("undo_apply.undone", False, before), ("undo_apply.redone", True, applied)):
        harness.move(x, y)
        yield 0.2
        harness.key('Z', x=x, y=y, ctrl=True, shift=shift)
        yield from harness.wait_until(lambda: action_name(name) == reference["action"],
                                      f"{key}: the target's action back", timeout=10.0, required=False)
        compare(key, target_state(name), reference)


def steps():
    objects = scene.build(mk, walk60)
    target = objects["target"]
    # Decided as the Reference Pose's refresh button does: its menus then name what Auto chose, "(Match)" the
    # widest of what they show.
    harness.report("reference_pose.result", sorted(bpy.ops.motionkit.reference_pose()))
    harness.report("reference_pose.shown", sorted({f"({mode.capitalize()})" for mode, _ in
                                                   bpy.context.scene.motionkit_retarget.reference_pose
                                                   .decided().values()}))
    yield 0.3
    view = harness.area('VIEW_3D')
    # Nothing in the viewport is read here: without its overlays (the rigs' bones, a Rigify rig's 706 among
    # them) llvmpipe redraws the tall window for each screenshot in less time.
    view.spaces[0].overlay.show_overlays = False
    yield from harness.show_sidebar(view)
    yield from harness.open_tab(harness.region(view, 'UI'), watch)
    words = yield from open_closed_panels(view, "sidebar-object", (("Plant Feet", "Height In"),
                                                                   ("Solver", "Iterations")))
    pairs = bpy.context.scene.motionkit_retarget.pairs
    prefixes = [mk.core.display_names.shared_prefix(getattr(p, side) for p in pairs) for side in ("source", "target")]
    harness.report("bone_map.rows", [[mk.core.display_names.strip(p.source, prefixes[0]),
                                      mk.core.display_names.strip(p.target, prefixes[1])] for p in pairs[:6]])
    harness.report("bone_map.sources", [mk.core.display_names.strip(p.source, prefixes[0]) for p in pairs])

    # The Full-body IK panel's rows, all that a click on an effector or on Live changes: read alone, a
    # seventh of the sidebar's height, where it would take tesseract as many times as long.
    ik_rows = (harness.find_words(words, "Solver")[0]["y"] - 12, harness.find_words(words, "Full-body IK")[0]["y"] + 12)

    # A click on a row picks that effector, whatever part of the row it lands on, and changes
    # nothing else; the box below then names it. The rows are where the sidebar's reading above shows them.
    header = harness.find_words(words, "Effectors (mixamorig:*)")
    row = header and harness.find_words([w for w in words if w["y"] < header[0]["y"]], "LeftFoot")
    pins_before = [e.pin for e in target.motionkit_ik.effectors]
    if row:
        # On the row's icon, where the pin button was: past the name, short of the list's + and - column.
        side = harness.region(view, 'UI')
        x = min(row[0]["x"] + 90, side.x + side.width - 70)
        yield from harness.click(x, row[0]["y"])
        yield from harness.wait_until(lambda: target.motionkit_ik.active_effector != 0, "the clicked row to be active",
                                      timeout=3.0, required=False)
    yield from harness.redrawn(watch)
    harness.report("effector.clicked_row_found", bool(row))
    harness.report("effector.active", target.motionkit_ik.active_effector)
    harness.report("effector.pins_unchanged", pins_before == [e.pin for e in target.motionkit_ik.effectors])
    words = read_sidebar("sidebar-effector", view, ik_rows)
    harness.report("effector.box_names_it", bool(harness.find_words(words, "Selected Effector"))
                   and bool(harness.find_words(words, "mixamorig:LeftFoot", name=True)))

    # The Live toggle says its state, and a click turns it on.
    live = harness.find_words(words, "Live: Off")
    harness.report("live.off_readable", bool(live))
    if live:
        yield from harness.click(live[0]["x"], live[0]["y"])
        yield from harness.wait_until(lambda: target.motionkit_ik.live, "Live to turn on", timeout=3.0,
                                      required=False)
    yield from harness.redrawn(watch)
    harness.report("live.on_after_click", target.motionkit_ik.live)
    words = read_sidebar("sidebar-live", view, ik_rows)
    harness.report("live.on_readable", bool(harness.find_words(words, "Live: On")))
    target.motionkit_ik.live = False

    # Pose mode: the same tab, drawn for the bones.
    with harness.override(area_=view):
        bpy.ops.object.posemode_toggle()
        bpy.ops.pose.select_all(action='SELECT')
    yield from harness.redrawn(watch)
    yield from open_closed_panels(view, "sidebar-pose", (("Plant Feet", "Height In"), ("Solver", "Iterations")))

    # Dialogs, as a click on their buttons opens them.
    for name, operator in (("dialog-resample", bpy.ops.motionkit.resample_keys),
                           ("dialog-reduce", bpy.ops.motionkit.reduce_keys),
                           ("dialog-schemes", bpy.ops.motionkit.bone_map_scheme),
                           ("dialog-filter", bpy.ops.motionkit.filter_keys)):
        harness.move(view.x + view.width // 2, view.y + view.height // 2)
        before = yield from harness.settled_screenshot(shot(name + "-before"))
        with harness.override(area_=view):
            operator('INVOKE_DEFAULT')
        _, box = yield from popup_words(name, before)
        harness.key('ESC', x=view.x + view.width // 2, y=view.y + view.height // 2)
        yield from harness.popup_gone(before, box, shot(name + "-not-closed"))

    # Redo panels: the last operation's settings in the viewport's corner.
    with harness.override(area_=view):
        bpy.ops.object.mode_set(mode='OBJECT')
    for obj in bpy.context.view_layer.objects:
        obj.select_set(obj == objects["capture"])
    bpy.context.view_layer.objects.active = objects["capture"]
    for name, operator, title, last in (("redo-reduce", bpy.ops.motionkit.reduce_keys, "Reduce Keys",
                                         "Samples per Frame"),
                                        ("redo-resample", bpy.ops.motionkit.resample_keys, "Resample Keys",
                                         "Output")):
        with harness.override(area_=view):
            result = operator('EXEC_DEFAULT', True)
        harness.report(f"{name}.result", sorted(result))
        yield from redo_panel_open(view, name, title, last)

    # File browsers: import and export, each option group in its sub-panel.
    for name, operator in (("browser-import", bpy.ops.motionkit.import_bvh),
                           ("browser-export", bpy.ops.motionkit.export_bvh)):
        with harness.override(area_=view):
            operator('INVOKE_DEFAULT')
        for _ in range(20):
            yield 0.25
            windows = bpy.context.window_manager.windows
            browser = windows[len(windows) - 1]
            files = next((a for a in browser.screen.areas if a.type == 'FILE_BROWSER'), None)
            side = files and next((r for r in files.regions if r.type == 'TOOL_PROPS' and r.width > 1), None)
            if side is not None:
                break
        assert side is not None, f"{name}: no file browser with options: {[a.type for a in browser.screen.areas]}"
        # A new window draws its first frame a moment after it opens: read once it stands drawn.
        words, blank = yield from harness.read_until(shot(name), lambda: side, lambda ws: ws,
                                                     f"{name}: the options drawn", timeout=8.0, win=browser)
        harness.report(f"{name}.words", harness.plain(words))
        harness.report(f"{name}.blank", blank)
        harness.key('ESC', win=browser, x=files.x + files.width // 2, y=files.y + files.height // 2)
        yield from harness.wait_until(lambda: not any(a.type == 'FILE_BROWSER' for w in bpy.context.window_manager.windows
                                                      for a in w.screen.areas), f"{name}: the browser to close")

    # Menus: File > Import, and each animation editor's Key menu.
    menus = [("menu-import", None, "TOPBAR_MT_file_import")]
    timeline = harness.area('DOPESHEET_EDITOR')
    for name, ui_type, menu in (("menu-graph-key", 'FCURVES', "GRAPH_MT_key"),
                                ("menu-dopesheet-key", 'DOPESHEET', "DOPESHEET_MT_key")):
        menus.append((name, ui_type, menu))
    for name, ui_type, menu in menus:
        where = view
        if ui_type is not None:
            timeline.ui_type = ui_type
            where = timeline
        harness.move(where.x + where.width // 2, where.y + where.height // 2)
        before = yield from harness.settled_screenshot(shot(name + "-before"))
        with harness.override(area_=where):
            bpy.ops.wm.call_menu(name=menu)
        _, box = yield from popup_words(name, before)
        harness.key('ESC', x=where.x + where.width // 2, y=where.y + where.height // 2)
        yield from harness.popup_gone(before, box, shot(name + "-not-closed"))

    # A part of the body over the character's own walk: the Body preset ticks the arms' rows (the others
    # drawn dim), the keys go into its current action; a click on Retarget, as a user makes it.
    settings = bpy.context.scene.motionkit_retarget
    with harness.override(area_=view):
        bpy.ops.object.mode_set(mode='OBJECT')
    target = settings.target  # the operators' undo steps above remade the objects: found again here
    walk = target.animation_data.action
    legs_before = {(fc.data_path, fc.array_index): fc.evaluate(10.0) for fc in mk.animdata.fcurves(walk, target)
                   if "UpLeg" in fc.data_path}
    settings.parts, settings.into = "arms", "current"
    harness.report("parts.ticked", sorted(p.target for p in settings.pairs if p.use))
    yield from harness.redrawn(watch)
    read_sidebar("sidebar-parts", view)
    with harness.override(area_=view):
        result = bpy.ops.motionkit.retarget('EXEC_DEFAULT', True)
    harness.report("parts.result", sorted(result))
    harness.report("parts.same_action", target.animation_data.action == walk)
    harness.report("parts.legs_kept", bool(legs_before) and all(
        fc.evaluate(10.0) == legs_before[(fc.data_path, fc.array_index)] for fc in mk.animdata.fcurves(walk, target)
        if (fc.data_path, fc.array_index) in legs_before))
    settings.into = "nla"
    yield from harness.redrawn(watch)
    read_sidebar("sidebar-parts-nla", view)
    settings.parts, settings.into = "whole", "new"

    # The live preview in the window: Preview, an option changed, the timer remakes it; Cancel.
    walk = target.animation_data.action
    with harness.override(area_=view):
        harness.report("preview.result", sorted(bpy.ops.motionkit.retarget_preview('EXEC_DEFAULT')))
    first = settings.preview.action.as_pointer() if settings.preview.action else None
    settings.root_motion = "in_place"
    yield from harness.wait_until(lambda: settings.preview.action is not None
                                  and settings.preview.action.as_pointer() != first,
                                  "the preview remade after a change", timeout=5.0, required=False)
    harness.report("preview.remade", settings.preview.action is not None
                   and settings.preview.action.as_pointer() != first)
    harness.report("preview.seconds", settings.preview.seconds)
    harness.report("preview.plays_it", target.animation_data.action == settings.preview.action)
    yield from harness.redrawn(watch)
    read_sidebar("sidebar-preview", view)
    with harness.override(area_=view):
        bpy.ops.motionkit.retarget_preview_cancel('EXEC_DEFAULT')
    harness.report("preview.cancelled", target.animation_data.action == walk
                   and "MotionKit Preview" not in bpy.data.actions)
    settings.root_motion = "scaled"

    # Props and the channel map in the Options sub-panel, filled in as a user does: Hand picked, a click on
    # the map's + button for each pair of names, the names typed into its row.
    settings.prop_space = "hand"
    for source_name, target_name in CHANNEL_PAIRS:
        with harness.override(area_=view):
            harness.report(f"channels.add.{source_name}",
                           sorted(bpy.ops.motionkit.channel_map_add('EXEC_DEFAULT', True)))
        pair = settings.channel_pairs[settings.active_channel_pair]
        pair.source, pair.target = source_name, target_name
    harness.report("channels.map", settings.retarget_options().channel_map)
    yield from harness.redrawn(watch)
    words = read_sidebar("sidebar-channels", view)
    read_rows_again("sidebar-channels", view, words, "Source Name", "Plant Feet")
    settings.property_unset("prop_space")
    settings.channel_pairs.clear()

    yield from preview_apply_undo(view, settings.target.name)

    # A Rigify rig as the retarget's target: the Controls sub-panel says what it is, its arms' and legs'
    # FK/IK choice active.
    import rigify_rig
    with harness.override(area_=view):
        bpy.ops.object.mode_set(mode='OBJECT')
        rig, _ = rigify_rig.generate()
    bpy.context.scene.motionkit_retarget.target = rig
    harness.report("rigify.described", mk.control_rigs.describe(rig))
    yield from harness.redrawn(watch)
    read_sidebar("sidebar-rigify", view)


harness.run(steps())
