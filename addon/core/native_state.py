"""The loaded native core (or why it is missing), shared by every module of the add-on. The compiled
module and its build_info.json sit at the package's top (motionkit/_native*.so), one level above core/."""
import os

from . import native_loader

status = native_loader.load(__package__.rpartition(".")[0], os.path.dirname(os.path.dirname(__file__)))


def native():
    """The native core module; raises RuntimeError with the reason when it is not usable."""
    if not status.ok:
        raise RuntimeError(status.message)
    return status.module
