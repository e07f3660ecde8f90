"""The loaded native core (or why it is missing), shared by every module of the add-on."""
import os

from . import native_loader

status = native_loader.load(__package__, os.path.dirname(__file__))


def draw_status(layout) -> None:
    """Draws the core's versions, or the reason it did not load, in a UI layout."""
    if status.ok:
        info = status.module.build_info()
        col = layout.column(align=True)
        col.label(text=f"MotionKit {info['version']}: native core loaded", icon='CHECKMARK')
        col.label(text=f"Eigen {info['eigen']}, pybind11 {info['pybind11']}, Python {info['python']}")
        return
    box = layout.box()
    box.alert = True
    col = box.column(align=True)
    col.label(text="MotionKit cannot run in this Blender:", icon='ERROR')
    # The message is long; split it into label-sized lines.
    words, line = status.message.split(), ""
    for word in words:
        if len(line) + len(word) > 70:
            col.label(text=line)
            line = ""
        line += (" " if line else "") + word
    if line:
        col.label(text=line)


def native():
    """The native core module; raises RuntimeError with the reason when it is not usable."""
    if not status.ok:
        raise RuntimeError(status.message)
    return status.module


def poll_native(operator_class) -> bool:
    """For an operator's poll: False, with the reason shown, when the core is not usable."""
    if not status.ok:
        operator_class.poll_message_set(status.message)
        return False
    return True
