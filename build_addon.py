#!/usr/bin/env python3
"""Build MotionKit's native module for one Blender's Python and package the add-on.

    python3 build_addon.py --blender /usr/bin/blender

asks that Blender for its Python (version, extension suffix, include folder),
configures and builds the CMake project in build/py<XY>/ against it, and
writes dist/motionkit-<version>-<platform>-py<XY>.zip holding the package
motionkit/ (from addon/) with the module, build_info.json and the extension
manifest. The zip installs as a legacy add-on on Blender 3.4 (bl_info) and as
an extension on 4.2 and later (blender_manifest.toml).

For Blender 4.3 from Debian 13 (trixie) and Blender 5.2 from Debian sid run it
inside their chroots (tools/chroot.sh):
    tools/chroot.sh trixie run python3 build_addon.py --blender /usr/bin/blender
    tools/chroot.sh sid run python3 build_addon.py --blender /usr/bin/blender
"""
from __future__ import annotations

import argparse
import ast
import json
import os
import re
import shutil
import subprocess
import sys
import zipfile

ROOT = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(ROOT, "addon", "core"))
import native_loader  # noqa: E402  (pure Python: naming rules shared with the add-on)

PROBE = r"""
import bpy, json, os, sys, sysconfig
# sys.executable is whatever python3.X comes first on PATH (a pyenv, say); the
# interpreter Blender embeds is the one its own sysconfig was built with.
exe = os.path.join(sysconfig.get_config_var("BINDIR") or "", "python%d.%d" % sys.version_info[:2])
print("MOTIONKIT_PYINFO " + json.dumps({
    "python": "%d.%d" % sys.version_info[:2],
    "python_full": sys.version.split()[0],
    "executable": exe if os.access(exe, os.X_OK) else sys.executable,
    "ext_suffix": sysconfig.get_config_var("EXT_SUFFIX"),
    "include": sysconfig.get_paths()["include"],
    "blender": bpy.app.version_string,
}))
"""

def fail(message: str) -> None:
    print(f"build_addon.py: {message}", file=sys.stderr)
    sys.exit(1)


def ask_blender(blender: str) -> dict:
    cmd = [blender, "--background", "--factory-startup", "--python-expr", PROBE]
    try:
        out = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    except FileNotFoundError:
        fail(f"no Blender at {blender!r}")
    for line in out.stdout.splitlines():
        if line.startswith("MOTIONKIT_PYINFO "):
            return json.loads(line.split(" ", 1)[1])
    fail(f"{blender} did not report its Python (exit {out.returncode}):\n{out.stdout}\n{out.stderr}")
    raise AssertionError  # unreachable


def check_interpreter(info: dict) -> None:
    """The module must be built against the Python that Blender embeds.

    Blender finds its standard library through the first python3.X on PATH; a
    pyenv or virtualenv there makes it report (and run) a foreign Python.
    """
    out = subprocess.run([info["executable"], "-c", "import sys; print(sys.version.split()[0])"],
                         capture_output=True, text=True)
    found = out.stdout.strip()
    if found != info["python_full"]:
        fail(f"Blender runs Python {info['python_full']}, but the interpreter it reports, "
             f"{info['executable']}, is Python {found or '?'}: a python3 earlier on PATH "
             f"(pyenv, virtualenv) is being picked up. Run with PATH=/usr/bin:/bin first.")


def project_version() -> str:
    with open(os.path.join(ROOT, "CMakeLists.txt"), encoding="utf-8") as f:
        match = re.search(r"project\(motionkit VERSION (\d+\.\d+\.\d+)", f.read())
    if not match:
        fail("CMakeLists.txt has no project(motionkit VERSION x.y.z)")
    return match.group(1)


def bl_info_version() -> str:
    with open(os.path.join(ROOT, "addon", "__init__.py"), encoding="utf-8") as f:
        tree = ast.parse(f.read())
    for node in tree.body:
        if isinstance(node, ast.Assign) and any(getattr(t, "id", "") == "bl_info" for t in node.targets):
            return ".".join(map(str, ast.literal_eval(node.value)["version"]))
    fail("addon/__init__.py has no bl_info")
    raise AssertionError  # unreachable


def manifest(version: str, platform_tag: str) -> str:
    # Blender 4.2+ reads this; Blender 3.4 ignores it and reads bl_info.
    return f'''schema_version = "1.0.0"
id = "motionkit"
version = "{version}"
name = "MotionKit"
tagline = "Retarget motion, full-body IK and keyframe resampling, natively"
maintainer = "MotionKit developers"
type = "add-on"
tags = ["Animation", "Rigging"]
blender_version_min = "4.2.0"
license = ["SPDX:GPL-3.0-or-later"]
platforms = ["{platform_tag}"]

[permissions]
files = "Reads and writes motion files (BVH) and presets the user chooses"
'''


def cmake_options(executable: str, include: str, everything: bool, werror: bool) -> list[str]:
    """CMake's options for a build for the Python at executable; everything: the native tests and
    benchmarks too (they need GoogleTest and Google Benchmark, which the add-on alone does not)."""
    extras = "ON" if everything else "OFF"
    return [f"-DPython_EXECUTABLE={executable}", f"-DPython_INCLUDE_DIR={include}",
            f"-DMOTIONKIT_WERROR={'ON' if werror else 'OFF'}",
            f"-DMOTIONKIT_BUILD_TESTS={extras}", f"-DMOTIONKIT_BUILD_BENCHMARKS={extras}"]


def compiler_cache() -> tuple[list[str], dict]:
    """CMake's launcher option and the environment for ccache, where it is installed (MOTIONKIT_CCACHE=0 turns
    it off): the same sources compiled by the same compiler are not compiled again, from any clone. Paths are
    hashed relative to the clone (CCACHE_BASEDIR, CCACHE_NOHASHDIR), so a fresh clone in another folder, as
    CI makes, finds what an earlier one compiled; the cache lives in the user's cache folder (in a chroot,
    the chroot's own), beside the chroots."""
    launcher = shutil.which("ccache") if os.environ.get("MOTIONKIT_CCACHE", "1") != "0" else None
    # The build runs its own jobs: under `make -j` (make test) the inherited MAKEFLAGS would hand CMake's make
    # the outer jobserver and have it warn that its -j resets it.
    env = {k: v for k, v in os.environ.items() if k not in ("MAKEFLAGS", "MFLAGS", "MAKELEVEL")}
    if launcher:
        env.update(CCACHE_BASEDIR=ROOT, CCACHE_NOHASHDIR="1")
    return [f"-DCMAKE_CXX_COMPILER_LAUNCHER={launcher or ''}"], env


def build(info: dict, build_dir: str, everything: bool, werror: bool, jobs: int) -> str:
    launcher, env = compiler_cache()
    configure = ["cmake", "-S", ROOT, "-B", build_dir, *launcher,
                 *cmake_options(info["executable"], info["include"], everything, werror)]
    subprocess.run(configure, check=True, env=env)
    subprocess.run(["cmake", "--build", build_dir, "-j", str(jobs), "--target", "all" if everything else "_native"],
                   check=True, env=env)
    module = os.path.join(build_dir, "_native" + info["ext_suffix"])
    if not os.path.isfile(module):
        fail(f"the build did not produce {module}: its suffix does not match Blender's Python "
             f"({info['ext_suffix']}); check Python_EXECUTABLE")
    return module


def addon_sources(addon_dir: str) -> list[str]:
    """The add-on's files, relative to addon/: every module of its tree, the stub of the native module,
    bone_mapping's scheme presets (core/presets/*.json) and the control rig maps (core/presets/control_rigs/);
    no caches."""
    sources = []
    for folder, dirs, names in os.walk(addon_dir):
        dirs[:] = sorted(d for d in dirs if d != "__pycache__")
        relative = os.path.relpath(folder, addon_dir)
        sources += [os.path.normpath(os.path.join(relative, n)) for n in sorted(names)
                    if n.endswith((".py", ".pyi")) or (n.endswith(".json") and os.path.basename(folder) in ("presets", "control_rigs"))]
    return sources


def package(info: dict, module: str, version: str, platform_tag: str, dist: str) -> str:
    os.makedirs(dist, exist_ok=True)
    path = os.path.join(dist, native_loader.zip_name(version, platform_tag, info["python"]))
    build_info = {
        "version": version,
        "python": info["python"],
        "platform": platform_tag,
        "ext_suffix": info["ext_suffix"],
        "blender": info["blender"],
    }
    addon_dir = os.path.join(ROOT, "addon")
    sources = addon_sources(addon_dir)
    tmp = path + ".tmp"
    with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as z:
        for name in sources:
            z.write(os.path.join(addon_dir, name), f"motionkit/{name}")
        z.write(module, f"motionkit/{os.path.basename(module)}")
        z.writestr("motionkit/build_info.json", json.dumps(build_info, indent=2) + "\n")
        z.writestr("motionkit/blender_manifest.toml", manifest(version, platform_tag))
    os.replace(tmp, path)
    return path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--blender", required=True, help="the Blender executable to build for")
    parser.add_argument("--build-dir", help="CMake build folder (default build/py<XY>)")
    parser.add_argument("--dist", default=os.path.join(ROOT, "dist"), help="where the zip goes")
    parser.add_argument("--all", action="store_true",
                        help="also build the native tests and benchmarks in the same folder")
    parser.add_argument("--werror", action="store_true", default=os.environ.get("MOTIONKIT_WERROR") == "ON",
                        help="treat compiler warnings as errors (default: $MOTIONKIT_WERROR == ON)")
    parser.add_argument("-j", "--jobs", type=int, default=os.cpu_count() or 2)
    args = parser.parse_args()

    version = project_version()
    if bl_info_version() != version:
        fail(f"bl_info version {bl_info_version()} differs from CMakeLists.txt's {version}")
    info = ask_blender(args.blender)
    check_interpreter(info)
    print(f"build_addon.py: Blender {info['blender']} runs Python {info['python_full']} "
          f"({info['executable']}, {info['ext_suffix']})")
    build_dir = args.build_dir or os.path.join(ROOT, "build", "py" + info["python"].replace(".", ""))
    module = build(info, build_dir, args.all, args.werror, args.jobs)
    path = package(info, module, version, native_loader.running_platform(), args.dist)
    print(f"build_addon.py: wrote {os.path.relpath(path, os.getcwd())}")


if __name__ == "__main__":
    main()
