"""MotionKit in a real Blender window (Xvfb, mesa's software OpenGL), as a person sees it: every panel,
dialog, redo panel, file browser and menu drawn, read back from the screen's pixels (tests/blender/ui/),
judged here. Screenshots stay in out/ui/<Blender version>/ for a person to look at.

Each scenario runs in a windowed Blender of its own, started by this (background) Blender's tests with
the same zip; any Python error printed while it draws fails the test.
"""
import json
import os
import re
import shutil
import subprocess
import sys

import bpy
import pytest

import conftest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "ui"))
import screen_text  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
OUT = os.path.join(ROOT, "out", "ui", "%d.%d" % bpy.app.version[:2])
READY = "MOTIONKIT-UI-READY"
# A tall screen, so that every panel of the sidebar fits without scrolling; the sidebar keeps Blender's
# default width.
SCENARIO_SECONDS = 1800
SCREEN = "-screen 0 1400x3800x24"
# The first X display tried, one range per Blender: `make test` runs two Blenders' suites at once, and a
# chroot's Blender sees its own /tmp (xvfb-run -a looks for free displays by their lock files there) but
# shares the host's abstract X sockets.
DISPLAY = 99 + 100 * (bpy.app.version[0] - 3)
# Lines in a window session's output that are not errors of MotionKit's (checked by eye when added).
NOT_OURS = (re.compile(r"^(Info|Warning): "), re.compile(r"^UI "), re.compile(r"ALSA|libdecor|Xlib|GLX"))
PROBLEM = re.compile(r"Traceback|Error|rna_ui|not found|Exception", re.IGNORECASE)


def run_window(script: str, args: list, folder) -> dict:
    """Runs a scenario in a windowed Blender under Xvfb; returns its reports, with the error lines it
    printed after installing the add-on under 'problems' and its whole output under 'output'."""
    xvfb = shutil.which("xvfb-run")
    if xvfb is None:
        pytest.fail("xvfb-run is missing: tools/install_deps.sh (or the chroot's setup) installs xvfb")
    if shutil.which("tesseract") is None:
        pytest.fail("tesseract is missing: tools/install_deps.sh (or the chroot's setup) installs tesseract-ocr")
    cmd = [xvfb, "-n", str(DISPLAY), "-a", "-s", SCREEN, bpy.app.binary_path, "--factory-startup",
           "--enable-event-simulate", "--python-exit-code", "1", "--python", os.path.join(HERE, "ui", script), "--", *args]
    # A scenario takes minutes, several times longer on a loaded machine: the bound catches a hang only.
    out = subprocess.run(cmd, capture_output=True, text=True, timeout=SCENARIO_SECONDS,
                         env=conftest.fresh_blender_env(folder))
    report = {"problems": [], "output": out.stdout[-4000:] + out.stderr[-4000:], "returncode": out.returncode}
    for stream in (out.stdout, out.stderr):
        for line in stream.split(READY, 1)[1].splitlines() if READY in stream else ["no add-on: " + stream[-2000:]]:
            if line.startswith("UI "):
                key, value = line[3:].split(" ", 1)
                report[key] = json.loads(value)
            elif PROBLEM.search(line) and not any(p.search(line) for p in NOT_OURS):
                report["problems"].append(line)
    with open(os.path.join(OUT, script.replace(".py", ".json")), "w") as f:
        json.dump(report, f, indent=1)  # what was read, beside the screenshots, for a person checking a failure
    return report


def scenario(script, shared_dir, tmp_path_factory) -> dict:
    """A scenario of tests/blender/ui/ on walk60, its pictures in OUT."""
    os.makedirs(OUT, exist_ok=True)
    walk60 = os.path.join(shared_dir, "data", "bvh", "walk60.bvh")
    return run_window(script, [os.environ["MOTIONKIT_ZIP"], walk60, OUT], tmp_path_factory.mktemp(script[:-3]))


@pytest.fixture(scope="module")
def panels(shared_dir, tmp_path_factory):
    """Every surface drawn once (tests/blender/ui/panels.py), its screenshots in out/ui/."""
    return scenario("panels.py", shared_dir, tmp_path_factory)


def unread(report, name, phrases, bone_names=False):
    """The phrases a person could not read in the picture, each as a whole label (see screen_text), in any
    of its readings (popups are read twice, at two sizes)."""
    assert name + ".words" in report, f"{name} was never drawn: {report.get('error') or report['output']}"
    missed = screen_text.missing(report[name + ".words"], phrases, name=bone_names)
    if name + ".words-again" in report:
        missed = screen_text.missing(report[name + ".words-again"], missed, name=bone_names)
    return missed


def cut_labels(report, name, allowed=None):
    """Every word of the picture's readings that carries an ellipsis (a label Blender cut), but those of
    which allowed(reading) accepts a reading (the word alone or joined to a neighbour on its line)."""
    cut = []
    for key in (name + ".words", name + ".words-again"):
        for word, readings in screen_text.cut_words(report.get(key, [])):
            if allowed is None or not any(allowed(r) for r in readings):
                cut.append(word)
    return sorted(set(cut))


def test_every_surface_draws_without_a_python_error(panels):
    assert "error" not in panels, panels["error"]
    assert panels.get("done") is True, panels["output"]
    assert panels["problems"] == [], panels["problems"]


SCREENS = ("sidebar-object", "sidebar-pose", "dialog-resample", "dialog-reduce", "dialog-schemes", "dialog-filter",
           "redo-reduce",
           "redo-resample", "browser-import", "browser-export", "menu-import", "menu-graph-key",
           "menu-dopesheet-key", "sidebar-parts", "sidebar-parts-nla", "sidebar-preview",
           "sidebar-channels", "sidebar-rigify")


@pytest.mark.parametrize("name", SCREENS)
def test_screenshots_are_not_blank(panels, name):
    blank = panels.get(name + ".blank")
    assert blank is not None, f"{name} was never drawn"
    assert blank["colours"] > 20 and blank["spread"] > 5, blank
    assert os.path.getsize(os.path.join(OUT, name + ".png")) > 1000


SIDEBAR_LABELS = (
    # MotionKit
    "Motion Capture (BVH)", "Import", "Export", "Keys", "Resample", "Reduce", "Filter", "Mirror",
    "Fix Foot Sliding",
    # Retarget, Bone Map, Options, Plant Feet
    "Armature", "File", "Source", "Target", "Retarget", "Bone Map", "Load", "Save", "Auto-map", "Schemes",
    "Source Bone", "Target Bone", "Body", "Whole Body", "Into", "Preview", "Carry", "Scale", "Properties",
    "Shape Keys", "Props", "Two Hands", "Channel Map", "Source Name", "Target Name",
    "Reference Pose", "Trunk", "Left Arm", "Right Arm", "Left Leg", "Right Leg", "Left Fingers",
    "Right Fingers", "Options", "Match Poses", "Rest pose", "Root Motion", "Scaled", "Floor Root",
    "Align Facing", "Frame Range", "From Clip", "Overwrite", "Plant Feet", "Height In",
    "Height Out", "Speed In", "Speed Out", "Shortest", "Blend", "Slides and Pivots",
    # Library
    "Library", "Clips", "Names", "Output", "Keep Actions", "Folder", "Panel's Bone Map", "Retarget panel's options",
    "Retarget Library",
    # Controls (its Arms and Legs rows are greyed out on the scene's plain rig, too faint to read)
    "Controls", "Bones (no control rig)", "Every Frame", "Reduce Keys", "Map (other rigs)",
    # Full-body IK, Solver, Bake
    "Full-body IK", "Effectors (mixamorig:*)", "Selected Effector", "Position", "Orientation", "Weight", "Chain",
    "Solve", "Solver", "Method", "Damped LS", "Iterations", "Damping", "Smoothing", "Move", "Rotate", "Limits",
    "Scene Range", "New Action", "Bake", "Natural Defaults",
)


def test_a_part_of_the_body_through_the_panel(panels):
    """The Body preset ticks the arms' rows only; Retarget into the current action keeps the walk's legs; the
    choices read whole on the sidebar, the NLA track's blend and influence once it is chosen."""
    ticked = panels["parts.ticked"]
    assert ticked and all(any(k in n for k in ("Shoulder", "Arm", "Hand")) for n in ticked)
    assert panels["parts.result"] == ["FINISHED"] and panels["parts.same_action"] and panels["parts.legs_kept"]
    assert unread(panels, "sidebar-parts", ("Body", "Arms", "Into", "Current Action")) == []
    assert unread(panels, "sidebar-parts-nla", ("Into", "NLA Track", "Blend", "Replace", "Influence")) == []


def test_the_live_preview_in_the_window(panels):
    """Preview plays the retarget, the window's timer remakes it when an option changes, Apply and Cancel
    read whole, and Cancel gives the target its own action back."""
    assert panels["preview.result"] == ["FINISHED"] and panels["preview.remade"] and panels["preview.plays_it"]
    assert panels["preview.cancelled"]
    updated = f"Updated in {panels['preview.seconds']:.2f} seconds"
    assert unread(panels, "sidebar-preview", ("Apply", "Cancel", updated)) == []


def test_props_and_the_channel_map_in_the_panel(panels):
    """The Options sub-panel's Props and Two Hands rows and, under Carry, the channel map: two pairs added by
    its + button and typed in, each name read whole at the default sidebar width, none cut."""
    assert all(panels[f"channels.add.{s}"] == ["FINISHED"] for s in ("smile", "blink"))
    assert panels["channels.map"] == {"smile": "grin", "blink": "eyeBlink"}
    assert unread(panels, "sidebar-channels", ("Props", "Hand", "Two Hands", "Carry", "Channel Map", "Source Name",
                                               "Target Name")) == []
    assert unread(panels, "sidebar-channels", ("smile", "grin", "blink", "eyeBlink"), bone_names=True) == []
    assert cut_labels(options_rows(panels, "sidebar-channels"), "sidebar-channels") == []


def options_rows(report, name) -> dict:
    """The picture's readings cut to the Options sub-panel's rows: from its header down to Plant Feet's (the
    second reading is of the channel map's rows alone)."""
    words = report[name + ".words"]
    top = max((w["y"] for w in words if w["text"] == "Options"), default=None)
    assert top is not None, f"no Options header in {name}"
    bottom = max((w["y"] for w in words if w["text"] == "Plant" and w["y"] < top), default=-1.0)
    return {name + ".words": [w for w in words if bottom < w["y"] < top],
            name + ".words-again": report.get(name + ".words-again", [])}


def test_undo_after_preview_apply_in_the_window(panels):
    """Preview, Apply, then ctrl+Z pressed in the window: the target plays its own action again, every key
    and handle as before to the bit, every bone where Blender evaluated it before (exactly: the same keys
    evaluated the same way), the applied and the preview's actions gone; ctrl+shift+Z brings the applied
    keys back, to the bit."""
    assert panels["undo_apply.preview"] == ["FINISHED"] and panels["undo_apply.apply"] == ["FINISHED"]
    assert panels["undo_apply.previewed"] == "MotionKit Preview"
    applied, before = panels["undo_apply.applied.action"]
    assert applied != before and not panels["undo_apply.applied.keys_same"]
    assert panels["undo_apply.applied.pose"] > 1e-2  # the retarget moves the bones: the undo has work to do
    assert panels["undo_apply.undone.action"] == [before, before]
    assert panels["undo_apply.undone.keys_same"] and panels["undo_apply.undone.pose"] == 0.0
    now, then = panels["undo_apply.undone.actions"]
    assert now == then and applied not in now and "MotionKit Preview" not in now
    assert panels["undo_apply.redone.action"] == [applied, applied]
    assert panels["undo_apply.redone.keys_same"] and panels["undo_apply.redone.pose"] == 0.0
    assert panels["undo_apply.redone.actions"][0] == panels["undo_apply.redone.actions"][1]


def test_the_reference_pose_names_what_auto_decided_whole(panels):
    """After its refresh button each chain's menu names what Auto chose ("(Keep)", "(Match)"), read whole at
    the default sidebar width (the side-by-side menus cut it to "(Ke...")."""
    assert panels["reference_pose.result"] == ["FINISHED"] and panels["reference_pose.shown"]
    assert unread(panels, "sidebar-object", panels["reference_pose.shown"]) == []


@pytest.mark.parametrize("mode", ["object", "pose"])
def test_every_sidebar_label_is_whole_at_the_default_width(panels, mode):
    """At Blender's default sidebar width no label is cut ("Source Ar...", "Regularis..."): each is read
    whole, and no word on the sidebar carries an ellipsis but a bone map row's source name cut in the middle
    (its column is narrower than some names)."""
    assert unread(panels, f"sidebar-{mode}", SIDEBAR_LABELS) == []
    sources = panels["bone_map.sources"]
    assert cut_labels(panels, f"sidebar-{mode}", lambda w: any(cut_from(w, s) for s in sources)) == []


def test_a_rigify_target_is_named_with_its_limb_choices(panels):
    """A rig generated by Rigify as the target: the Controls sub-panel says so, its Arms and Legs rows active
    (readable, where on a plain rig they are greyed out)."""
    assert panels["rigify.described"] == "Rigify (controls)"
    assert unread(panels, "sidebar-rigify", ["Rigify (controls)", "Arms", "Legs", "Every Frame"]) == []


def cut_from(word: str, name: str) -> bool:
    """Whether word reads as name cut in the middle: its start, an ellipsis, its end (one letter misread)."""
    parts = re.split(r"\u2026|\.\.\.?", word)
    if len(parts) != 2 or min(map(len, parts)) < 2 or sum(map(len, parts)) >= len(name):
        return False
    head, tail = parts
    slips = sum(a != b for a, b in zip(head, name)) + sum(a != b for a, b in zip(tail, name[-len(tail):]))
    return slips <= 1


def test_lists_show_bone_names_at_the_default_width(panels):
    """The bone map's rows and the effectors show names, not only icons and x buttons: each row's
    target whole, each source whole or, when longer than its column, cut in the middle (its first and last
    letters either side of an ellipsis); the effectors' names whole, their shared prefix said once above. Names are no words tesseract
    knows: one letter of each may be misread ('Spinez') or a thin one lost ('Shoulder'), never the last."""
    rows = panels["bone_map.rows"]
    assert len(rows) >= 6
    read = [w["text"] for w in panels["sidebar-object.words"]]
    # tesseract may read an underscore beside the ellipsis as a space: "lowe..." "torso"
    read += [a + b for a, b in zip(read, read[1:])]
    for source, target in rows:
        assert unread(panels, "sidebar-object", [target], bone_names=True) == [], (target, read)
        assert not unread(panels, "sidebar-object", [source], bone_names=True) or any(
            cut_from(w, source) for w in read), (source, read)
    assert unread(panels, "sidebar-object", ["LeftHand", "LeftFoot", "RightFoot"], bone_names=True) == []


def test_a_click_on_an_effector_row_picks_it_and_changes_nothing_else(panels):
    """The row clicked (where the pin icon is) becomes the active one, highlighted, and the box under
    the list names it; its pin is not toggled by the click."""
    assert panels["effector.clicked_row_found"], "the effector's name is not on screen"
    assert panels["effector.active"] == 1
    assert panels["effector.pins_unchanged"]
    assert panels["effector.box_names_it"]


def test_the_live_toggle_says_its_state(panels):
    """Live reads 'Live: Off', a click turns it on and it then reads 'Live: On'."""
    assert panels["live.off_readable"]
    assert panels["live.on_after_click"]
    assert panels["live.on_readable"]


DIALOG_LABELS = {
    "dialog-resample": ("Resample Keys", "Timing", "Frame Rate", "Change Rate", "Location/Scale", "Rotation",
                        "Output"),
    "dialog-reduce": ("Reduce Keys", "Space", "Tolerance", "Rotation Tolerance", "Samples per Frame"),
    "dialog-schemes": ("Map by Schemes", "Source Scheme", "Target Scheme"),
    "dialog-filter": ("Filter Keys", "Filter", "Butterworth", "Cut-off", "Order", "Channels", "Keys", "Every Frame",
                      "Scene Range"),
    "redo-reduce": ("Reduce Keys", "Space", "Tolerance", "Rotation Tolerance", "Samples per Frame"),
    "redo-resample": ("Resample Keys", "Timing", "Frame Rate", "Change Rate", "Location/Scale", "Rotation",
                      "Output"),
}


@pytest.mark.parametrize("name", sorted(DIALOG_LABELS))
def test_dialogs_and_redo_panels_are_readable(panels, name):
    assert unread(panels, name, DIALOG_LABELS[name]) == []
    assert cut_labels(panels, name) == []


BROWSER_LABELS = {
    "browser-import": ("Transform", "Scale", "Forward", "Up", "Animation", "Rotation", "Start Frame",
                       "At Scene Rate", "Scene", "From Clip", "Frame Rate", "Frame Range"),
    "browser-export": ("Transform", "Scale", "Forward", "Up", "Animation", "Order", "Start", "End"),
}


@pytest.mark.parametrize("name", sorted(BROWSER_LABELS))
def test_file_browsers_group_options_in_sub_panels(panels, name):
    """The options in sub-panels, as Blender's importers have them, none cut off."""
    assert unread(panels, name, BROWSER_LABELS[name]) == []
    assert cut_labels(panels, name) == []


def test_menus_name_motionkit_in_blenders_capitalisation(panels):
    """File > Import reads 'Motion Capture (.bvh) [MotionKit]'; the Key menus of the Graph Editor
    and the Dope Sheet hold Resample, Reduce, Filter Keys and Mirror Action."""
    assert unread(panels, "menu-import", ["Motion Capture (.bvh) [MotionKit]"]) == []
    assert "Capture" in [w["text"] for w in panels["menu-import.words"]]
    for menu in ("menu-graph-key", "menu-dopesheet-key"):
        assert unread(panels, menu, ["Resample Keys [MotionKit]", "Reduce Keys [MotionKit]",
                                     "Filter Keys [MotionKit]", "Mirror Action [MotionKit]"]) == []


@pytest.fixture(scope="module")
def session(shared_dir, tmp_path_factory):
    """A whole first session through the UI (tests/blender/ui/session.py)."""
    return scenario("session.py", shared_dir, tmp_path_factory)


def test_a_whole_session_through_the_ui(session):
    """Import, retarget, resample, IK with Live clicked on, save, open, move the target, undo: operators
    invoked in the window as clicks invoke them, each its own undo step."""
    assert "error" not in session, session["error"]
    assert session.get("done") is True, session["output"]
    assert session["problems"] == [], session["problems"]
    # The 60 fps capture sets the scene's rate and range, its bones selected.
    assert session["import.scene_rate"] == [60, 1.0]
    assert session["import.frames"] == [1, 182]
    assert session["import.bones_selected"]
    # The retarget plays at the capture's rate, whole.
    assert session["retarget.action"]
    fps, start, end, keyed = session["retarget.scene"]
    assert fps == 60 and [start, end] == keyed
    assert session["resample.scene_rate"] == 30 and session["resample.keys"] == 91
    # Live reaches the goal, survives saving and opening, follows a move, and an undo of the move.
    assert session["ik.live_on"] and session["ik.reached"] < 1e-3
    assert session["reopen.live_on"]
    assert session["move.goal_moved"] > 0.1 and session["move.reached"] < 1e-3
    assert session["undo.goal_back"] < 1e-6 and session["undo.reached"] < 1e-3
