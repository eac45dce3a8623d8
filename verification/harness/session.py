# SPDX-License-Identifier: GPL-3.0-or-later
"""The process environment of anything that imports ``bpy``.

Tests, the demo and the benchmark import bpy through :func:`prepare`, which
first points Blender's user folders and the temp folder at throwaway
directories (so the real user configuration is never read or written) and
then puts Blender's bundled Python packages first on ``sys.path`` (Cycles'
OSL script-node update imports ``oslquery``, which only works with the
bundled OpenImageIO).

Importing this module never imports bpy.  Run as a script it renders a .blend
in a fresh process (see :func:`render_in_fresh_process`)::

    python -m verification.harness.session render SCENE.blend OUT.exr
"""

from __future__ import annotations

import argparse
import atexit
import importlib.util
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
import tomllib
import zipfile
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[2]
EXTENSION_ID = "reflection_models"
DEFAULT_REPO_MODULE = "rm_test"

# The user-folder overrides Blender reads at start-up, relative to the
# throwaway user-resources folder.
_USER_DIRS = {
    "BLENDER_USER_CONFIG": "config",
    "BLENDER_USER_SCRIPTS": "scripts",
    "BLENDER_USER_DATAFILES": "datafiles",
    "BLENDER_USER_EXTENSIONS": "extensions",
}

_state: dict = {}


# ---------------------------------------------------------------------------
# Locating the installed bpy package (without importing it)

def bpy_package_dir() -> Path:
    """The folder of the installed ``bpy`` package; bpy is not imported."""
    spec = importlib.util.find_spec("bpy")
    if spec is None or not spec.submodule_search_locations:
        raise RuntimeError(f"bpy is not installed for {sys.executable}")
    return Path(list(spec.submodule_search_locations)[0])


def blender_resource_dir() -> Path:
    """Blender's bundled resources ``<bpy>/<X.Y>`` (scripts, datafiles, python)."""
    pkg = bpy_package_dir()
    found = sorted(
        p for p in pkg.iterdir()
        if p.is_dir() and (p / "scripts").is_dir() and p.name.replace(".", "").isdigit()
    )
    if len(found) != 1:
        raise RuntimeError(f"expected one <X.Y> resource folder in {pkg}, found {found}")
    return found[0]


def blender_version() -> tuple[int, int]:
    """(major, minor) of the installed bpy, from its resource folder name."""
    major, minor = blender_resource_dir().name.split(".")
    return int(major), int(minor)


def bundled_site_packages() -> list[Path]:
    """Blender's bundled site-packages (OpenImageIO, oslquery, MaterialX, ...)."""
    return sorted(blender_resource_dir().glob("python/lib/python3*/site-packages"))


def use_bundled_site_packages() -> list[str]:
    """Put Blender's bundled site-packages first on ``sys.path``.

    Safe to call before bpy is imported, and idempotent.  Raises if a
    different OpenImageIO (e.g. pip's) is already imported: ``oslquery`` would
    then fail with a pybind11 type error (the extension's own
    :func:`~addon.backends.osl.compile.put_first_on_path`, which it uses
    where ``oslquery`` does not import).
    """
    from addon.backends.osl.compile import put_first_on_path

    paths = [str(p) for p in bundled_site_packages()]
    put_first_on_path(paths)
    return paths


# ---------------------------------------------------------------------------
# Preparing the process

def prepare(tmp_root: str | os.PathLike | None = None):
    """Isolate Blender's user folders and temp folder, import and return bpy.

    ``tmp_root`` (default: a new folder from :func:`tempfile.mkdtemp`, removed
    at exit) receives ``user/`` (BLENDER_USER_RESOURCES with config, scripts,
    datafiles and extensions), ``tmp/`` (TMPDIR, for Blender and Python) and
    ``repos/`` (local extension repositories).  Idempotent: later calls return
    the same bpy.  Raises if bpy was imported before the first call.
    """
    if _state.get("bpy") is not None:
        if tmp_root is not None and Path(tmp_root).resolve() != _state["root"]:
            raise RuntimeError(f"bpy_env already prepared with root {_state['root']}")
        return _state["bpy"]
    if "bpy" in sys.modules:
        raise RuntimeError("bpy was imported before verification.harness.session.prepare(): its user folders are not isolated")

    owned = tmp_root is None
    if owned:
        root = Path(tempfile.mkdtemp(prefix="rm-bpy-")).resolve()
        atexit.register(cleanup)
    else:
        root = Path(tmp_root).resolve()
    user = root / "user"
    tmp = root / "tmp"
    for path in (user, tmp, root / "repos"):
        path.mkdir(parents=True, exist_ok=True)
    os.environ["BLENDER_USER_RESOURCES"] = str(user)
    for var, sub in _USER_DIRS.items():
        (user / sub).mkdir(exist_ok=True)
        os.environ[var] = str(user / sub)
    os.environ["TMPDIR"] = str(tmp)
    tempfile.tempdir = str(tmp)

    use_bundled_site_packages()
    import bpy  # noqa: E402  (must follow the environment set-up)
    use_bundled_site_packages()  # again, in case importing bpy touched sys.path

    prefs = bpy.context.preferences
    prefs.use_preferences_save = False  # never write userpref.blend, even a temp one
    _state.update(bpy=bpy, root=root, user=user, tmp=tmp, owned=owned)
    return bpy


def cleanup() -> None:
    """Remove the throwaway root if :func:`prepare` created it.

    Runs at normal interpreter exit; call it yourself before ``os._exit``.
    bpy stays imported: call it only when the process is about to end.
    """
    if _state.get("owned") and _state.get("root") is not None:
        shutil.rmtree(_state["root"], ignore_errors=True)
        _state["owned"] = False


def exit_process(status: int) -> None:
    """End a process that imported bpy: flush, :func:`cleanup`, then
    ``os._exit`` (bpy 4.5 can hang at interpreter exit)."""
    sys.stdout.flush()
    sys.stderr.flush()
    cleanup()
    os._exit(status)


def prepared_root() -> Path:
    """The throwaway root folder chosen by :func:`prepare`."""
    if "root" not in _state:
        raise RuntimeError("verification.harness.session.prepare() has not been called")
    return _state["root"]


def reset_scene() -> None:
    """Load an empty home file; installed extensions and repositories stay.

    (``read_factory_settings`` would unregister extensions and drop custom
    repositories.)
    """
    bpy = prepare()
    bpy.ops.wm.read_homefile(use_empty=True)


# ---------------------------------------------------------------------------
# Extensions

def manifest_from_zip(zip_path: str | os.PathLike) -> dict:
    """The parsed ``blender_manifest.toml`` at the root of an extension zip."""
    with zipfile.ZipFile(zip_path) as zf:
        return tomllib.loads(zf.read("blender_manifest.toml").decode("utf-8"))


def _find_repo(bpy, repo_module: str):
    for repo in bpy.context.preferences.extensions.repos:
        if repo.module == repo_module:
            return repo
    return None


def ensure_repository(repo_module: str = DEFAULT_REPO_MODULE):
    """A local (user) extension repository ``repo_module`` under the temp root."""
    bpy = prepare()
    repo = _find_repo(bpy, repo_module)
    if repo is None:
        directory = _state["root"] / "repos" / repo_module
        directory.mkdir(parents=True, exist_ok=True)
        repo = bpy.context.preferences.extensions.repos.new(
            name=repo_module, module=repo_module, custom_directory=str(directory))
        repo.enabled = True
    return repo


def repository_directory(repo_module: str = DEFAULT_REPO_MODULE) -> Path:
    """The folder of local repository ``repo_module`` (created if needed)."""
    return Path(ensure_repository(repo_module).directory)


def install_extension(zip_path: str | os.PathLike, repo_module: str = DEFAULT_REPO_MODULE) -> str:
    """Install ``zip_path`` like "Install from Disk" and enable it.

    Returns the module name ``bl_ext.<repo_module>.<id>``.  Raises
    RuntimeError if the add-on is not enabled afterwards (a refused install
    still returns FINISHED).
    """
    bpy = prepare()
    zip_path = Path(zip_path).resolve()
    pkg_id = manifest_from_zip(zip_path)["id"]
    ensure_repository(repo_module)
    module_name = f"bl_ext.{repo_module}.{pkg_id}"
    result = bpy.ops.extensions.package_install_files(
        filepath=str(zip_path), repo=repo_module, enable_on_install=True)
    if result != {"FINISHED"} or module_name not in bpy.context.preferences.addons:
        raise RuntimeError(
            f"installing {zip_path} returned {set(result)} and {module_name} is "
            f"{'' if module_name in bpy.context.preferences.addons else 'not '}enabled")
    return module_name


def enable_extension(module_name: str) -> None:
    """Enable an installed extension add-on; raises if it does not stick."""
    bpy = prepare()
    bpy.ops.preferences.addon_enable(module=module_name)
    if module_name not in bpy.context.preferences.addons:
        raise RuntimeError(f"{module_name} could not be enabled")


def disable_extension(module_name: str) -> None:
    """Disable an extension add-on; raises if it stays enabled."""
    bpy = prepare()
    bpy.ops.preferences.addon_disable(module=module_name)
    if module_name in bpy.context.preferences.addons:
        raise RuntimeError(f"{module_name} is still enabled")


def uninstall_extension(pkg_id: str = EXTENSION_ID, repo_module: str = DEFAULT_REPO_MODULE) -> None:
    """Disable and uninstall ``pkg_id`` from local repository ``repo_module``.

    Raises RuntimeError if the add-on is still enabled or its folder remains.
    """
    bpy = prepare()
    repo = _find_repo(bpy, repo_module)
    if repo is None:
        raise RuntimeError(f"no extension repository {repo_module!r}")
    module_name = f"bl_ext.{repo_module}.{pkg_id}"
    result = bpy.ops.extensions.package_uninstall(repo_directory=repo.directory, pkg_id=pkg_id)
    leftover = Path(repo.directory) / pkg_id
    if result != {"FINISHED"} or module_name in bpy.context.preferences.addons or leftover.exists():
        raise RuntimeError(
            f"uninstalling {module_name} returned {set(result)}; enabled: "
            f"{module_name in bpy.context.preferences.addons}; folder left: {leftover.exists()}")


# ---------------------------------------------------------------------------
# Rendering in a fresh process

def render_in_fresh_process(
    blend_path: str | os.PathLike,
    out_path: str | os.PathLike,
    *,
    scene: str | None = None,
    frame: int | None = None,
    multilayer: bool = False,
    python: str | os.PathLike | None = None,
    timeout: float = 600,
) -> dict:
    """Render ``blend_path`` to the EXR ``out_path`` in a new Python process.

    The child imports bpy through :func:`prepare` with new throwaway user
    folders, so no extension is installed there; it opens the file, renders
    its scene (or ``scene``) at ``frame`` (default: the file's current frame)
    as a 32-bit float OpenEXR (multilayer if asked) and writes it.  Uses this
    interpreter unless ``python`` is given.  Returns the child's report:
    ``{"path", "seconds", "addons", "blender"}``; raises RuntimeError with the
    child's output if it fails.
    """
    out_path = Path(out_path).resolve()
    cmd = [str(python or sys.executable), "-m", "verification.harness.session", "render",
           str(Path(blend_path).resolve()), str(out_path)]
    if scene is not None:
        cmd += ["--scene", scene]
    if frame is not None:
        cmd += ["--frame", str(frame)]
    if multilayer:
        cmd.append("--multilayer")
    env = {k: v for k, v in os.environ.items()
           if not (k.startswith("BLENDER_USER_") or k == "BLENDER_USER_RESOURCES")}
    env["PYTHONPATH"] = os.pathsep.join([str(REPO_ROOT)] + [p for p in [env.get("PYTHONPATH")] if p])
    proc = subprocess.run(cmd, cwd=REPO_ROOT, env=env, capture_output=True, text=True, timeout=timeout)
    report = None
    for line in reversed(proc.stdout.splitlines()):
        if line.startswith("RENDER-REPORT "):
            report = json.loads(line[len("RENDER-REPORT "):])
            break
    if proc.returncode != 0 or report is None or not out_path.is_file():
        raise RuntimeError(
            f"fresh-process render of {blend_path} failed (exit {proc.returncode})\n"
            f"--- stdout ---\n{proc.stdout[-4000:]}\n--- stderr ---\n{proc.stderr[-4000:]}")
    return report


def _render_main(args: argparse.Namespace) -> int:
    bpy = prepare()
    bpy.ops.wm.open_mainfile(filepath=args.blend, load_ui=False)
    scene = bpy.data.scenes[args.scene] if args.scene else bpy.context.scene
    window = bpy.context.window
    if window is not None and window.scene != scene:
        # Drivers and animation are evaluated for the window's scene: another
        # scene would render with its frame-1 pose after frame_set().
        window.scene = scene
    if args.frame is not None:
        scene.frame_set(args.frame)
    image = scene.render.image_settings
    if args.multilayer:
        if hasattr(image, "media_type"):  # Blender 5.x
            image.media_type = "MULTI_LAYER_IMAGE"
        else:
            image.file_format = "OPEN_EXR_MULTILAYER"
    else:
        if hasattr(image, "media_type"):
            image.media_type = "IMAGE"
        image.file_format = "OPEN_EXR"
    image.color_depth = "32"
    scene.render.use_file_extension = False
    scene.render.filepath = args.out
    start = time.perf_counter()
    bpy.ops.render.render(write_still=True, scene=scene.name)
    seconds = time.perf_counter() - start
    report = {
        "path": args.out,
        "seconds": seconds,
        "addons": sorted(a.module for a in bpy.context.preferences.addons),
        "blender": bpy.app.version_string,
    }
    print("RENDER-REPORT " + json.dumps(report), flush=True)
    status = 0 if Path(args.out).is_file() else 1
    cleanup()
    os._exit(status)  # bpy 4.5 can hang at interpreter exit


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m verification.harness.session")
    sub = parser.add_subparsers(dest="command", required=True)
    render = sub.add_parser("render", help="render a .blend to an EXR with no extension installed")
    render.add_argument("blend")
    render.add_argument("out")
    render.add_argument("--scene")
    render.add_argument("--frame", type=int)
    render.add_argument("--multilayer", action="store_true")
    args = parser.parse_args(argv)
    return _render_main(args)


if __name__ == "__main__":
    sys.exit(main())
