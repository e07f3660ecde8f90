"""Loads the compiled core, or says in plain words why it cannot.

No bpy here: the compatibility rules are tested in plain Python. The built
package carries build_info.json, written by build_addon.py, naming the Python
and platform the module was compiled for; a mismatch is reported naming both
versions instead of surfacing as an import traceback.
"""
from __future__ import annotations

import importlib
import json
import os
import platform
import sys
from dataclasses import dataclass, field
from types import ModuleType

BUILD_INFO_FILE = "build_info.json"


@dataclass
class NativeStatus:
    module: ModuleType | None = None
    message: str = ""
    build_info: dict = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        return self.module is not None


def running_python() -> str:
    return f"{sys.version_info.major}.{sys.version_info.minor}"


def running_platform() -> str:
    """Blender's extension platform tag for this machine (linux-x64, ...)."""
    system = {"Linux": "linux", "Darwin": "macos", "Windows": "windows"}.get(
        platform.system(), platform.system().lower())
    machine = platform.machine().lower()
    arch = {"x86_64": "x64", "amd64": "x64", "aarch64": "arm64", "arm64": "arm64"}.get(machine, machine)
    return f"{system}-{arch}"


def zip_name(version: str, platform_tag: str, python: str) -> str:
    return f"motionkit-{version}-{platform_tag}-py{python.replace('.', '')}.zip"


def read_build_info(package_dir: str) -> dict:
    path = os.path.join(package_dir, BUILD_INFO_FILE)
    with open(path, encoding="utf-8") as f:
        return json.load(f)


def mismatch_message(info: dict, python: str, platform_tag: str) -> str:
    """Empty when the build fits this interpreter, else what is wrong and what to install."""
    built_python = info.get("python", "?")
    built_platform = info.get("platform", "?")
    version = info.get("version", "?")
    if built_python == python and built_platform == platform_tag:
        return ""
    built_for = f"Python {built_python} on {built_platform}"
    if info.get("blender"):
        built_for += f" (Blender {info['blender']})"
    return (f"MotionKit {version} was built for {built_for}, but this Blender runs "
            f"Python {python} on {platform_tag}. Install {zip_name(version, platform_tag, python)} "
            f"instead (python3 build_addon.py --blender <this blender> builds it).")


def load(package: str, package_dir: str) -> NativeStatus:
    try:
        info = read_build_info(package_dir)
    except FileNotFoundError:
        return NativeStatus(message=(
            f"MotionKit's native module is missing ({BUILD_INFO_FILE} not found in {package_dir}): "
            "this is the add-on's source folder, not a built package. "
            "Build and install the zip with build_addon.py."))
    except (OSError, ValueError) as ex:
        return NativeStatus(message=f"MotionKit's {BUILD_INFO_FILE} cannot be read: {ex}")
    message = mismatch_message(info, running_python(), running_platform())
    if message:
        return NativeStatus(message=message, build_info=info)
    try:
        module = importlib.import_module(f"{package}._native")
    except ImportError as ex:
        return NativeStatus(build_info=info, message=(
            f"MotionKit's native module failed to load under Python {running_python()}: {ex}"))
    return NativeStatus(module=module, build_info=info)
