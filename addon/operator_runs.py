"""What MotionKit's operators share: run the work, show progress, report the outcome.

An error the work raises (bad input, a bad file) is reported and the operator
cancels; the work computes everything before it changes the file, so nothing
has changed.
"""
from __future__ import annotations


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
