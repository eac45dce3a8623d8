# SPDX-License-Identifier: GPL-3.0-or-later
"""Build the extension zip with Blender's own extension tool.

    python -m tools.build_zip  (this module: verification.harness.package)

Stages ``build/stage/reflection_models`` (the manifest and the contents of
``addon/`` at its root), validates it with
``blender_ext.py validate`` (tags checked against Blender's list), then runs
``blender_ext.py build`` into ``dist/``.  The tool is found inside the
installed bpy package without importing bpy.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

from .session import blender_resource_dir

REPO_ROOT = Path(__file__).resolve().parents[2]
MANIFEST = REPO_ROOT / "blender_manifest.toml"
ADDON_DIR = REPO_ROOT / "addon"
LICENSE = REPO_ROOT / "LICENSE"
STAGE_ROOT = REPO_ROOT / "build" / "stage"
DIST_DIR = REPO_ROOT / "dist"
# RM_PACKAGE_DIR: stage into <it>/stage and build into <it>/dist instead (each
# parallel test worker builds its own zip: tests/conftest.py)
PACKAGE_DIR_VARIABLE = "RM_PACKAGE_DIR"


def _package_dir(default: Path, sub: str) -> Path:
    other = os.environ.get(PACKAGE_DIR_VARIABLE)
    return Path(other) / sub if other else default

_IGNORE = shutil.ignore_patterns("__pycache__", "*.pyc", "*.oso", ".*")


class ExtensionToolError(RuntimeError):
    """Blender's extension tool rejected the package."""


def read_manifest(path: Path = MANIFEST) -> dict:
    """The parsed manifest."""
    with open(path, "rb") as fh:
        return tomllib.load(fh)


def blender_ext_script() -> Path:
    """``<bpy>/<X.Y>/scripts/addons_core/bl_pkg/cli/blender_ext.py``."""
    path = blender_resource_dir() / "scripts" / "addons_core" / "bl_pkg" / "cli" / "blender_ext.py"
    if not path.is_file():
        raise FileNotFoundError(path)
    return path


def valid_tags_file() -> Path:
    """The tag list Blender's ``--command extension`` validates against."""
    path = blender_resource_dir() / "scripts" / "modules" / "_bpy_internal" / "extensions" / "tags.py"
    if not path.is_file():
        raise FileNotFoundError(path)
    return path


def run_blender_ext(*args: str) -> str:
    """Run Blender's extension tool; return its output, raise on failure."""
    cmd = [sys.executable, str(blender_ext_script()), *args]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    output = (proc.stdout + proc.stderr).strip()
    if proc.returncode != 0:
        raise ExtensionToolError(f"{' '.join(args[:1])} failed (exit {proc.returncode}):\n{output}")
    return output


def validate(path: str | Path) -> str:
    """Validate a source folder or a zip with Blender's tool and tag list."""
    return run_blender_ext("validate", "--valid-tags", str(valid_tags_file()), str(path))


def stage(stage_root: Path | None = None) -> Path:
    """Lay out the extension source folder; returns ``<stage_root>/<id>``
    (default: build/stage, or RM_PACKAGE_DIR's)."""
    stage_root = stage_root or _package_dir(STAGE_ROOT, "stage")
    manifest = read_manifest()
    dest = stage_root / manifest["id"]
    if dest.exists():
        shutil.rmtree(dest)
    shutil.copytree(ADDON_DIR, dest, ignore=_IGNORE)
    for name in ("blender_manifest.toml", "LICENSE"):
        if (dest / name).exists():
            raise RuntimeError(f"addon/{name} would clash with the staged {name}")
    shutil.copy2(MANIFEST, dest / "blender_manifest.toml")
    if LICENSE.is_file():
        shutil.copy2(LICENSE, dest / "LICENSE")
    return dest


def zip_path() -> Path:
    """Where :func:`build_zip` writes the package."""
    manifest = read_manifest()
    return _package_dir(DIST_DIR, "dist") / f"{manifest['id']}-{manifest['version']}.zip"


def build_zip() -> Path:
    """Stage, validate and build ``dist/<id>-<version>.zip``; returns its path."""
    source = stage()
    validate(source)
    out = zip_path()
    out.parent.mkdir(parents=True, exist_ok=True)
    out.unlink(missing_ok=True)
    run_blender_ext("build", "--valid-tags", str(valid_tags_file()),
                    "--source-dir", str(source), "--output-dir", str(out.parent))
    if not out.is_file():
        raise ExtensionToolError(f"the build reported success but {out} does not exist")
    return out
