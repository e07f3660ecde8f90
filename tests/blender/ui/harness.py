"""Drives a real Blender window (under Xvfb, software OpenGL) the way a person does: events through
Window.event_simulate (Blender started with --enable-event-simulate), operators invoked in the window's
context, screenshots through Blender's own screen.screenshot, and text read back from the pixels with
tesseract, so that a label Blender cut ("Regularis...") or a list row with no name is seen as a person
would see it.

A scenario is a generator of steps: each `yield` lets Blender run its event loop and redraw for a
moment (a number: that many seconds). Before a screenshot a scenario waits for what it is to show (a
region redrawn, a popup on screen, a property set) with wait_until and the polls built on it, never for a
fixed time: a slow machine only waits longer, up to the poll's timeout, which fails the scenario. What
the scenario finds is printed as `UI <key> <json>` lines for test_ui.py, which also fails on any Python error printed after the `MOTIONKIT-UI-READY` marker.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
import traceback

from screen_text import find_words  # noqa: F401  (scenarios use it through harness)

import bpy
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(HERE)))
for path in (os.path.join(ROOT, "tools"), os.path.join(ROOT, "blend_samples")):
    if path not in sys.path:
        sys.path.insert(0, path)

READY = "MOTIONKIT-UI-READY"
# What reading the screen cost, reported at the end for a person weighing the suite's time.
COST = {"ocr_calls": 0, "ocr_seconds": 0.0, "screenshots": 0, "screenshot_seconds": 0.0}


def report(key: str, value) -> None:
    print(f"UI {key} {json.dumps(value)}", flush=True)


def start(zip_path: str):
    """Installs the add-on, sets the preferences automation needs; returns the package."""
    import importlib

    import install_addon
    prefs = bpy.context.preferences
    prefs.view.show_splash = False
    prefs.view.use_save_prompt = False
    prefs.filepaths.use_auto_save_temporary_files = False
    # A menu opens under the pointer, on its first item; where that is a sub-menu (the Key menus'
    # Transform) it would open over the menu while the scenario waits for the picture to stand still, and
    # Escape would then close only the sub-menu.
    prefs.view.open_sublevel_delay = 40
    # The viewport's anti-aliasing redraws it eight times over on mesa's software OpenGL (1.8 s a frame of the
    # tall window against 0.8 s without); the scenarios read panels, menus and dialogs, not the viewport.
    prefs.system.viewport_aa = 'OFF'
    module = install_addon.install(zip_path)
    print(READY, file=sys.stderr, flush=True)
    print(READY, flush=True)
    return importlib.import_module(module)


def run(steps) -> None:
    """Runs a scenario (a generator) from a persistent timer, so it carries on across opening files; quits
    Blender at the end, or at the first exception (reported as UI error)."""
    iterator = iter(steps)

    def step():
        try:
            wait = next(iterator)
        except StopIteration:
            report("cost", {k: round(v, 1) for k, v in COST.items()})
            report("done", True)
            bpy.ops.wm.quit_blender()
            return None
        except Exception:
            report("error", traceback.format_exc())
            bpy.ops.wm.quit_blender()
            return None
        return 0.2 if wait is None else float(wait)

    bpy.app.timers.register(step, first_interval=0.5, persistent=True)


def wait_until(condition, what: str, timeout: float = 10.0, step: float = 0.1, required: bool = True):
    """A scenario step (`yield from`): lets Blender run until condition() is true. After timeout / step
    tries (timeout seconds of waiting, plus what the condition's own reading of the screen takes) an
    AssertionError naming `what`, or, with required=False, it goes on (the caller reports what it sees)."""
    for _ in range(max(1, int(round(timeout / step)))):
        if condition():
            return True
        yield step
    if condition():
        return True
    if required:
        raise AssertionError(f"waited {timeout:g} s for {what}")
    return False


# ---------------------------------------------------------------------------------------------------------
# Where things are

def window():
    return bpy.context.window_manager.windows[0]


def area(kind: str, win=None):
    win = win or window()
    return next(a for a in win.screen.areas if a.type == kind)


def region(area_, kind: str):
    return next(r for r in area_.regions if r.type == kind)


def override(win=None, area_=None, region_=None):
    """Context for an operator run in a window, as Blender gives it to a click there."""
    win = win or window()
    kwargs = {"window": win, "screen": win.screen}
    if area_ is not None:
        kwargs["area"] = area_
        kwargs["region"] = region_ or region(area_, 'WINDOW')
    return bpy.context.temp_override(**kwargs)


# ---------------------------------------------------------------------------------------------------------
# Input

def move(x: int, y: int, win=None) -> None:
    (win or window()).event_simulate('MOUSEMOVE', 'NOTHING', x=int(x), y=int(y))


def click(x: int, y: int, win=None, **modifiers):
    """A scenario step (`yield from`): the pointer moves there, Blender redraws (a button becomes active
    only under a pointer it has seen), then the button is pressed and released."""
    win = win or window()
    move(x, y, win)
    yield 0.2
    win.event_simulate('LEFTMOUSE', 'PRESS', x=int(x), y=int(y), **modifiers)
    win.event_simulate('LEFTMOUSE', 'RELEASE', x=int(x), y=int(y), **modifiers)
    # A panel header opens as the pointer moves on after the click (a press there may start a drag over
    # several headers), as a hand always does.
    move(x + 1, y, win)


def key(kind: str, win=None, x: int | None = None, y: int | None = None, **modifiers) -> None:
    win = win or window()
    x = win.width // 2 if x is None else x
    y = win.height // 2 if y is None else y
    win.event_simulate(kind, 'PRESS', x=int(x), y=int(y), **modifiers)
    win.event_simulate(kind, 'RELEASE', x=int(x), y=int(y), **modifiers)


# ---------------------------------------------------------------------------------------------------------
# Which sidebar tab is showing: a header-less, empty panel of the test's own in a category records that
# Blender drew it (wrapping the add-on's own draw methods crashes Blender 3.4)

DRAWN: set[str] = set()


def watch_category(category: str) -> str:
    """Registers the watcher of a sidebar category; returns the name open_tab waits for."""
    name = "MOTIONKIT_TEST_PT_watch_" + "".join(c for c in category if c.isalnum())

    def draw(self, context):
        DRAWN.add(name)

    panel = type(name, (bpy.types.Panel,), {
        "bl_label": "", "bl_space_type": 'VIEW_3D', "bl_region_type": 'UI', "bl_category": category,
        "bl_options": {'HIDE_HEADER'}, "bl_order": 10000, "draw": draw})
    bpy.utils.register_class(panel)
    return name


def redrawn(panel: str, timeout: float = 10.0):
    """A scenario step (`yield from`): waits until Blender draws the sidebar tab whose watcher is `panel`
    again, after whatever the scenario just changed."""
    DRAWN.discard(panel)
    yield from wait_until(lambda: panel in DRAWN, f"the sidebar to redraw ({panel})", timeout)


def show_sidebar(view):
    """Opens the 3D view's sidebar, as N does, and waits until it has slid open (a scenario step)."""
    view.spaces[0].show_region_ui = True
    yield 0.25  # drawn once before its size counts: a region not yet drawn has no tabs to set
    yield from wait_until(lambda: region(view, 'UI').width > 150, "the sidebar to open", timeout=10.0, step=0.25)


def open_tab(region_, panel: str, win=None):
    """Shows the sidebar tab whose watcher is `panel` (a scenario step: `yield from`): by setting the
    region's active category where that works (5.x, where a click on the active tab folds the sidebar to
    its tabs), else by clicking down the tab strip until the watcher draws (3.4, 4.3)."""
    win = win or window()
    prop = bpy.types.Region.bl_rna.properties.get("active_panel_category")
    if prop is not None and not prop.is_readonly:
        DRAWN.clear()
        try:
            region_.active_panel_category = panel.rsplit("_", 1)[1]
        except AttributeError:  # 4.3 lists it as writable but refuses it: its tabs are clicked instead
            pass
        for _ in range(10):
            yield 0.2
            if panel in DRAWN:
                return
    x = region_.x + region_.width - 10
    top = region_.y + region_.height - 8
    for y in range(top, region_.y, -12):
        DRAWN.clear()
        yield from click(x, y, win)
        yield 0.1
        if panel in DRAWN:
            return
    raise AssertionError(f"no sidebar tab shows {panel}")


# ---------------------------------------------------------------------------------------------------------
# Pixels

def screenshot(path: str | None, win=None) -> np.ndarray:
    """The window as the X server shows it (RGBA floats, rows from the top), also saved to path (unless
    None: the polls below look at many and save the one they settle on).

    Taken with xwd from the X server, as a person's screen grabber would: Blender's own screen.screenshot
    reads its GL front buffer, which Blender 4.3 and 5.2 on mesa's llvmpipe under Xvfb return black."""
    win = win or window()
    started = time.perf_counter()
    # Draw and swap now: what the last events changed is otherwise on screen only at Blender's next redraw,
    # which llvmpipe may not have reached yet.
    with bpy.context.temp_override(window=win):  # a file browser's temporary screen cannot be overridden
        bpy.ops.wm.redraw_timer(type='DRAW_WIN_SWAP', iterations=1)
    out = subprocess.run(["xwd", "-root", "-silent"], capture_output=True, timeout=60)
    assert out.returncode == 0, out.stderr.decode(errors="replace")
    screen = _xwd_pixels(out.stdout)
    top = screen.shape[0] - (win.y + win.height)
    pixels = screen[max(top, 0):top + win.height, max(win.x, 0):win.x + win.width]
    COST["screenshots"] += 1
    COST["screenshot_seconds"] += time.perf_counter() - started
    if path is not None:
        save_png(pixels, path)
    return pixels


def _xwd_pixels(data: bytes) -> np.ndarray:
    """RGBA floats, rows from the top, of an X window dump of a TrueColor screen (24 or 32 bits a pixel)."""
    header = np.frombuffer(data[:100], dtype=">u4")
    size, width, height, byte_order = int(header[0]), int(header[4]), int(header[5]), int(header[7])
    bits, line, colours = int(header[11]), int(header[12]), int(header[19])
    masks = [int(m) for m in header[14:17]]
    assert bits in (24, 32), f"xwd gave {bits} bits a pixel"
    start = size + 12 * colours
    rows = np.frombuffer(data[start:start + height * line], dtype=np.uint8).reshape(height, line)
    step = bits // 8
    pixel = rows[:, :width * step].reshape(height, width, step)
    out = np.ones((height, width, 4), dtype=np.float32)
    shifts = [(m & -m).bit_length() - 1 for m in masks]
    assert all(m >> shift == 0xFF and shift % 8 == 0 for m, shift in zip(masks, shifts)), \
        f"xwd gave channel masks {[hex(m) for m in masks]}, not a byte each"
    for c, shift in enumerate(shifts):  # each channel one whole byte, taken as it lies
        byte = shift // 8 if byte_order == 0 else step - 1 - shift // 8  # LSBFirst: the first byte is lowest
        np.divide(pixel[..., byte], np.float32(255.0), out=out[..., c], dtype=np.float32)
    return out


def load_png(path: str) -> np.ndarray:
    image = bpy.data.images.load(path, check_existing=False)
    try:
        w, h = image.size
        pixels = np.empty(w * h * 4, dtype=np.float32)
        image.pixels.foreach_get(pixels)
    finally:
        bpy.data.images.remove(image)
    return pixels.reshape(h, w, 4)[::-1]


def save_png(pixels: np.ndarray, path: str) -> None:
    os.makedirs(os.path.dirname(path), exist_ok=True)
    h, w = pixels.shape[:2]
    image = bpy.data.images.new("motionkit-ui-crop", w, h, alpha=True)
    try:
        image.pixels.foreach_set(np.ascontiguousarray(pixels[::-1], dtype=np.float32).ravel())
        image.filepath_raw = path
        image.file_format = 'PNG'
        image.save()
    finally:
        bpy.data.images.remove(image)


def crop(pixels: np.ndarray, box) -> np.ndarray:
    """box = (x, y, width, height) in window coordinates (y from the bottom, as Blender's regions)."""
    x, y, w, h = (int(v) for v in box)
    top = pixels.shape[0] - (y + h)
    return pixels[max(top, 0):top + h, max(x, 0):x + w]


def box_of(region_) -> tuple:
    return (region_.x, region_.y, region_.width, region_.height)


def _changed(before: np.ndarray, after: np.ndarray) -> np.ndarray:
    """Where a colour channel differs by more than 0.02, channel by channel (a sixth of the time numpy
    takes over the three at once on the tall window)."""
    changed = np.abs(after[..., 0] - before[..., 0]) > 0.02
    for channel in (1, 2):
        changed |= np.abs(after[..., channel] - before[..., channel]) > 0.02
    return changed


def changed_box(before: np.ndarray, after: np.ndarray):
    """(top, left, bottom, right) in rows from the top of where the pixels differ, or None."""
    if np.array_equal(before, after):
        return None
    changed = np.argwhere(_changed(before, after))
    if not len(changed):
        return None
    (top, left), (bottom, right) = changed.min(axis=0), changed.max(axis=0) + 1
    return int(top), int(left), int(bottom), int(right)


def settled_screenshot(path: str | None, win=None, timeout: float = 10.0):
    """A scenario step (`yield from`): takes screenshots until two running are the same (what the last
    events changed is drawn, nothing is sliding); returns the last, saved at path (unless None)."""
    last = None
    for _ in range(int(timeout / 0.2)):
        yield 0.2
        now = screenshot(None, win)
        if last is not None and changed_box(last, now) is None:
            if path is not None:
                save_png(now, path)
            return now
        last = now
    raise AssertionError(f"the window kept changing for {timeout:g} s ({path})")


def popup_box(before: np.ndarray, after: np.ndarray):
    """(top, left, bottom, right) of a popup that appeared between two screenshots, or None: the rows and
    then the columns where most pixels changed. A popup changes nearly every pixel it covers; a viewport
    redrawn beside it (its anti-aliasing starting again) changes only thin outlines, which stay out."""
    changed = _changed(before, after)
    per_row = changed.sum(axis=1)
    if not per_row.any():
        return None
    rows = np.flatnonzero(per_row >= 0.5 * per_row.max())
    per_column = changed[rows[0]:rows[-1] + 1].sum(axis=0)
    columns = np.flatnonzero(per_column >= 0.5 * per_column.max())
    return int(rows[0]), int(columns[0]), int(rows[-1]) + 1, int(columns[-1]) + 1


def _above_status_bar(win) -> int:
    """Rows of the window (from the top) above its status bar, whose hints change with the pointer and a
    popup by themselves. It lies below every other area (3.4 does not list it among the screen's areas)."""
    return win.height - min(a.y for a in win.screen.areas if a.type != 'STATUSBAR')


def popup_shown(before: np.ndarray, path: str, win=None, timeout: float = 10.0):
    """A scenario step (`yield from`): takes screenshots until a popup stands drawn (the box where they
    differ from `before` above the status bar is there and the same in two shots running); returns (pixels,
    box). A box that reaches the status bar goes on to the window's bottom: a menu may cover it."""
    box = last = after = None
    win = win or window()
    rows = _above_status_bar(win)
    for _ in range(int(timeout / 0.2)):
        yield 0.2
        after = screenshot(None, win)
        box = popup_box(before[:rows], after[:rows])
        if box is not None and box == last:
            save_png(after, path)
            top, left, bottom, right = box
            return after, (top, left, after.shape[0] if bottom >= rows else bottom, right)
        last = box
    raise AssertionError(f"no popup stood still on screen within {timeout:g} s ({path}): {box}")


def popup_gone(before: np.ndarray, box, path: str, win=None, timeout: float = 10.0):
    """A scenario step (`yield from`): takes screenshots until where the popup stood (box, from popup_shown)
    shows what it showed in `before` again, above the status bar; on a timeout the last is saved at path
    for a person to see."""
    win = win or window()
    top, left, bottom, right = box
    bottom = min(bottom, _above_status_bar(win))
    last = [None]

    def gone():
        last[0] = screenshot(None, win)
        return changed_box(before[top:bottom, left:right], last[0][top:bottom, left:right]) is None

    # The event loop handles the key that closes the popup first: a screenshot's redraw while the popup
    # still has its key waiting blocks Blender 3.4.
    yield 0.2
    if not (yield from wait_until(gone, "", timeout, step=0.2, required=False)):
        save_png(last[0], path)
        still = changed_box(before[top:bottom, left:right], last[0][top:bottom, left:right])
        raise AssertionError(f"the popup did not close within {timeout:g} s: {path} differs from before at "
                             f"{still} within its box {box}")


def not_blank(pixels: np.ndarray) -> dict:
    """How much the picture varies: a blank or single-colour frame has one colour and no spread."""
    rgb = np.round(pixels[..., :3] * 255).astype(np.int32).reshape(-1, 3)
    colours = len(np.unique(rgb[:, 0] * 65536 + rgb[:, 1] * 256 + rgb[:, 2]))
    return {"colours": int(colours), "spread": float(rgb.std())}


# ---------------------------------------------------------------------------------------------------------
# Reading the screen

def ocr(pixels: np.ndarray, origin, scale: int = 3) -> list[dict]:
    """Words tesseract reads in a crop (rows from the top) whose window position is origin = (x, y, w, h):
    each {'text', 'x', 'y', 'w', 'h', 'block', 'conf'} with the word's centre, width and height in window
    coordinates and the block tesseract put it in (screen_text groups words into labels by them). The crop is enlarged
    three times and turned into dark text on light, which tesseract reads best; the darkest channel makes
    white text as clear on a blue (pressed) button as on grey."""
    started = time.perf_counter()
    grey = pixels[..., :3].min(axis=2)
    grey = 1.0 - np.clip((grey - grey.min()) / max(float(np.ptp(grey)), 1e-6), 0.0, 1.0)
    big = np.kron(grey, np.ones((scale, scale)))
    rgba = np.dstack([big, big, big, np.ones_like(big)])
    with tempfile.TemporaryDirectory() as folder:
        png = os.path.join(folder, "crop.png")
        save_png(rgba, png)
        # One thread: tesseract's OpenMP threads fight Blender's for two cores and take five times as long
        # to read the same words.
        out = subprocess.run(["tesseract", png, "stdout", "--psm", "12", "tsv"], capture_output=True,
                             text=True, timeout=120, env=dict(os.environ, OMP_THREAD_LIMIT="1"))
    assert out.returncode == 0, out.stderr
    x0, y0, _, h0 = origin
    words = []
    for line in out.stdout.splitlines()[1:]:
        cols = line.split("\t")
        if len(cols) < 12 or not cols[11].strip():
            continue
        left, top, width, height, conf = (float(c) for c in cols[6:11])
        cx, cy = (left + width / 2) / scale, (top + height / 2) / scale
        words.append({"text": cols[11].strip(), "x": x0 + cx, "y": y0 + h0 - cy, "w": width / scale,
                      "h": height / scale, "block": int(cols[2]), "conf": conf})
    COST["ocr_calls"] += 1
    COST["ocr_seconds"] += time.perf_counter() - started
    return words


def plain(words: list[dict]) -> list[dict]:
    """Words as reported: text, centre and size to a tenth of a pixel (screen_text measures the spaces
    between words), block."""
    return [{"text": w["text"], "x": round(w["x"], 1), "y": round(w["y"], 1), "w": round(w["w"], 1),
             "h": round(w["h"], 1), "block": w["block"]} for w in words]


def read_still(path: str, region_, win=None, timeout: float = 10.0):
    """A scenario step (`yield from`): once the window stands still (settled_screenshot), the region's crop
    saved at path (the window at path's -window.png) and read; returns (words, how far from blank)."""
    pixels = yield from settled_screenshot(path.replace(".png", "-window.png"), win, timeout)
    part = crop(pixels, box_of(region_))
    save_png(part, path)
    return ocr(part, box_of(region_)), not_blank(part)


def read_until(path: str, get_region, accept, what: str, timeout: float = 10.0, win=None, required=True):
    """A scenario step (`yield from`): reads get_region()'s crop each time the window stands still
    (read_still) until accept(words) or timeout seconds; returns the last (words, blank). One reading of a
    still screen serves the wait and the report: no reading of a picture still moving, none twice."""
    end = time.monotonic() + timeout
    words, blank = [], None
    while True:
        region_ = get_region()
        if region_ is not None:
            words, blank = yield from read_still(path, region_, win, timeout)
            if accept(words):
                return words, blank
        if time.monotonic() > end:
            if required:
                raise AssertionError(f"waited {timeout:g} s for {what} ({path})")
            return words, blank
        yield 0.3


def read_region(path: str, region_, win=None, box=None) -> tuple[list[dict], dict]:
    """Screenshot of the window (saved at path's -window.png), the region's crop (or box's, in window
    coordinates) saved at path, the words read in it and how far from blank it is."""
    box = box or box_of(region_)
    pixels = screenshot(path.replace(".png", "-window.png"), win)
    part = crop(pixels, box)
    save_png(part, path)
    return ocr(part, box), not_blank(part)
