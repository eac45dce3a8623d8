# SPDX-License-Identifier: GPL-3.0-or-later
"""Session set-up shared by every test.

- The repository root goes on ``sys.path`` (``import addon.reference``,
  ``import verification.harness.session``).
- Blender's bundled site-packages go first on ``sys.path`` now, without
  importing bpy, so that any OpenImageIO a test imports is the copy Cycles'
  ``oslquery`` needs.
- Tests that need Blender take the session fixture ``bpy`` (never
  ``import bpy`` at module level): it calls :func:`verification.harness.session.prepare`,
  which isolates the user folders first.  Pure numpy tests never load bpy.
- Under pytest-xdist (``make test`` runs two workers) each worker stages
  and builds its own zip (``RM_PACKAGE_DIR``: a folder of the run's temp
  folder), so one worker's rebuild never removes the zip another installs.
- bpy 4.5 can hang at interpreter exit, so once bpy was imported the session
  ends with ``os._exit`` and the exit status pytest computed.
"""

import os
import sys
from pathlib import Path

import pytest

REPO_ROOT = Path(__file__).resolve().parent.parent
if str(REPO_ROOT) not in sys.path:
    sys.path.insert(0, str(REPO_ROOT))

from verification.harness import session as bpy_env  # noqa: E402  (needs the path above)

try:
    bpy_env.use_bundled_site_packages()
except RuntimeError:  # bpy not installed: tests that need it fail on the fixture
    pass

_WORKER = os.environ.get("PYTEST_XDIST_WORKER")
if _WORKER:
    import tempfile
    os.environ["RM_PACKAGE_DIR"] = tempfile.mkdtemp(prefix=f"rm-package-{_WORKER}-")

_exit_status = None


@pytest.fixture(scope="session")
def bpy():
    """The ``bpy`` module, imported with throwaway user and temp folders."""
    return bpy_env.prepare()


@pytest.fixture(scope="session")
def extension_zip():
    """The extension zip, built once per session with Blender's own tool."""
    from verification.harness.package import build_zip
    return build_zip()


@pytest.fixture
def installed_extension(bpy, extension_zip):
    """Module name of the extension, installed and enabled in the test
    repository (installed on first use, then kept for later tests)."""
    module_name = f"bl_ext.{bpy_env.DEFAULT_REPO_MODULE}.{bpy_env.EXTENSION_ID}"
    if module_name not in bpy.context.preferences.addons:
        module_name = bpy_env.install_extension(extension_zip)
    return module_name


def pytest_sessionfinish(session, exitstatus):
    global _exit_status
    _exit_status = int(exitstatus)


@pytest.hookimpl(trylast=True)
def pytest_unconfigure(config):
    if "bpy" in sys.modules and _exit_status is not None:
        # Let the terminal summary out before leaving without interpreter
        # shutdown (which can hang in bpy 4.5).
        sys.stdout.flush()
        sys.stderr.flush()
        bpy_env.cleanup()
        os._exit(_exit_status)


@pytest.fixture(scope="module")
def api(bpy):
    """The extension's scripting API, imported from the tree (a test module
    may define its own, e.g. the installed extension's)."""
    from addon import api as rm_api
    return rm_api


@pytest.fixture(scope="module")
def verify(bpy):
    from verification.suites import verify as v
    return v
