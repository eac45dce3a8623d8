# SPDX-License-Identifier: GPL-3.0-or-later
"""The OSL backend in Blender: the shaders as internal Script nodes.

A Script node in mode 'INTERNAL' is compiled from a text datablock written to
a temporary file, so it cannot ``#include`` the project's own headers:
:func:`inline_includes` pastes them in first.  :func:`make_script_node`
compiles headlessly with Cycles' own ``cycles.osl.update_script_node`` and
raises :class:`OSLCompileError` with the compiler's message on failure.

bpy is imported inside the functions only; importing this module needs no
Blender.
"""

from __future__ import annotations

import os
import re
import shutil
import sys
import tempfile
from pathlib import Path

# a project header: #include "rm_name.h" (or <rm_name.h>)
_INCLUDE_RE = re.compile(r'^[ \t]*#[ \t]*include[ \t]*[<"](rm_[^">]*\.h)[">][ \t]*(//.*)?$')


class OSLCompileError(RuntimeError):
    """An OSL shader failed to compile; the message holds the compiler output."""


def osl_dir() -> Path:
    """The folder of the extension's shaders and headers (beside this module,
    in the source tree and in the installed extension alike)."""
    return Path(__file__).resolve().parent / "shaders"


def inline_includes(source: str, search_dir, *, _seen=None) -> str:
    """Replace each ``#include "rm_*.h"`` line of ``source`` by the text of
    that header from ``search_dir``, recursively; a header already inlined is
    replaced by a comment the second time (include-once).  Other includes
    (``stdcycles.h``, ``stdosl.h``) are left as they are.  Raises
    ``FileNotFoundError`` for a missing project header."""
    seen = set() if _seen is None else _seen
    search_dir = Path(search_dir)
    out = []
    for line in source.splitlines():
        m = _INCLUDE_RE.match(line)
        if not m:
            out.append(line)
            continue
        name = m.group(1)
        if name in seen:
            out.append(f"// (already inlined: {name})")
            continue
        seen.add(name)
        path = search_dir / name
        if not path.is_file():
            raise FileNotFoundError(f"OSL header {name!r} not found in {search_dir}")
        body = inline_includes(path.read_text(encoding="utf-8"), search_dir, _seen=seen)
        out.append(f"// ---- begin {name} (inlined) ----")
        out.append(body.rstrip("\n"))
        out.append(f"// ---- end {name} ----")
    return "\n".join(out) + ("\n" if source.endswith("\n") else "")


def shader_source(shader_name: str, search_dir=None) -> str:
    """The inlined source of ``<search_dir>/<shader_name>.osl`` (``.osl`` may
    be given or omitted; ``search_dir`` defaults to :func:`osl_dir`)."""
    search_dir = Path(search_dir) if search_dir is not None else osl_dir()
    file_name = shader_name if shader_name.endswith(".osl") else shader_name + ".osl"
    path = search_dir / file_name
    return inline_includes(path.read_text(encoding="utf-8"), search_dir)


class _CaptureOutput:
    """Redirect the process's stdout and stderr file descriptors (the OSL
    compiler writes its errors there from C++) into a temporary file."""

    def __enter__(self):
        self.text = ""
        sys.stdout.flush()
        sys.stderr.flush()
        self._file = tempfile.TemporaryFile(mode="w+b")
        self._saved = []
        for fd in (1, 2):
            try:
                self._saved.append((fd, os.dup(fd)))
                os.dup2(self._file.fileno(), fd)
            except OSError:
                pass
        return self

    def __exit__(self, *exc):
        try:
            sys.stdout.flush()
            sys.stderr.flush()
        finally:
            for fd, saved in self._saved:
                os.dup2(saved, fd)
                os.close(saved)
            self._file.seek(0)
            self.text = self._file.read().decode("utf-8", "replace")
            self._file.close()
        return False


class _Compiling:
    """Context of one compile: Cycles writes its temporary ``.osl``/``.oso``
    through :mod:`tempfile` into a scratch folder removed afterwards (Cycles
    never deletes the ``.oso`` of an internal script), and the compiler's
    output is captured."""

    def __enter__(self):
        self.scratch = tempfile.mkdtemp(prefix="rm_osl_")
        self._saved_tempdir = tempfile.tempdir
        tempfile.tempdir = self.scratch
        self._capture = _CaptureOutput().__enter__()
        return self

    def __exit__(self, *exc):
        try:
            self._capture.__exit__(*exc)
        finally:
            tempfile.tempdir = self._saved_tempdir
            shutil.rmtree(self.scratch, ignore_errors=True)
        # name the datablock instead of the temporary file in messages
        # The compiler names the file by its absolute path, or relative to the
        # working directory when the scratch folder lies inside it.
        names = {self.scratch, os.path.relpath(self.scratch)}
        pattern = "|".join(re.escape(n) for n in sorted(names, key=len, reverse=True))
        self.text = re.sub(rf"(?:{pattern})[/\\][^:\s]*\.osl", "<text>", self._capture.text)
        return False


def _raise_compile_error(node, output, messages):
    name = node.script.name if node.script else node.filepath
    detail = "\n".join(m for m in (output.strip(), *messages) if m)
    detail = detail.replace("<text>", name)
    raise OSLCompileError(
        f"OSL compilation of {name!r} failed (line numbers count in the text "
        f"datablock, headers inlined):\n{detail}")


def put_first_on_path(paths) -> None:
    """Put ``paths`` (Blender's bundled site-packages) first on ``sys.path``,
    in order, so that Cycles' ``oslquery`` gets the bundled OpenImageIO it
    was built against.  Raises :class:`OSLCompileError` where another
    OpenImageIO is already imported (``oslquery`` cannot work in that
    process).  The test harness puts them there this way too, before it
    imports ``bpy``."""
    paths = [str(p) for p in paths]
    for p in reversed(paths):
        if p in sys.path:
            sys.path.remove(p)
        sys.path.insert(0, p)
    oiio = sys.modules.get("OpenImageIO")
    if oiio is not None and paths:
        origin = str(Path(getattr(oiio, "__file__", "") or "").resolve())
        if not any(origin.startswith(str(Path(p).resolve())) for p in paths):
            raise OSLCompileError(
                f"OpenImageIO was imported from {origin} before Blender's bundled copy "
                f"({', '.join(paths)}) was put on sys.path; oslquery cannot work in this "
                f"process: compile before importing OpenImageIO")


def _ensure_oslquery() -> None:
    """Make Cycles' ``oslquery`` importable, which its script-node update
    needs.  Blender's own Python finds it; the ``bpy`` module (the pip
    wheel) ships it in Blender's bundled site-packages but leaves that
    folder off ``sys.path``: :func:`put_first_on_path` puts it there."""
    try:
        import oslquery  # noqa: F401
        return
    except ImportError:
        pass
    import bpy

    local = Path(bpy.utils.resource_path('LOCAL'))
    bundled = sorted(local.glob("python/lib/python3*/site-packages"))
    put_first_on_path(bundled)
    try:
        import oslquery  # noqa: F401,F811
    except ImportError as e:
        raise OSLCompileError(f"cannot compile OSL shaders: Cycles' oslquery does not "
                              f"import ({e}); looked in {[str(p) for p in bundled]}") from e


def compile_script_node(node) -> None:
    """Compile the Script ``node`` with Cycles' ``update_script_node``: fills
    ``node.bytecode`` and creates the sockets.  Raises :class:`OSLCompileError`
    with the compiler output when it fails."""
    from cycles import osl as cycles_osl

    _ensure_oslquery()

    messages = []

    def report(kind, message):
        messages.append(f"{'/'.join(sorted(kind))}: {message}")

    with _Compiling() as compiling:
        ok = cycles_osl.update_script_node(node, report)
    if not ok or not node.bytecode:
        _raise_compile_error(node, compiling.text, messages)


def make_script_node(tree, shader_name: str, text_name: str | None = None, *,
                     search_dir=None, node=None):
    """Create (or refill ``node``) a ``ShaderNodeScript`` in mode 'INTERNAL' in
    ``tree`` running ``<search_dir>/<shader_name>.osl`` (default folder:
    :func:`osl_dir`) with its project headers inlined.

    The source goes to the text datablock ``text_name`` (default
    ``"<shader_name>.osl"``), created or overwritten.  The node is compiled
    headlessly (no need for the scene engine to be Cycles) so that
    ``node.bytecode`` is filled and its sockets exist.  Raises
    :class:`OSLCompileError` with the compiler's message on failure.
    """
    import bpy

    base = shader_name[:-4] if shader_name.endswith(".osl") else shader_name
    source = shader_source(base, search_dir)
    text_name = text_name or base + ".osl"
    text = bpy.data.texts.get(text_name)
    if text is None:
        text = bpy.data.texts.new(text_name)
    if text.as_string() != source:
        text.clear()
        text.write(source)
    if node is None:
        node = tree.nodes.new("ShaderNodeScript")
        node.name = node.label = base
    node.mode = 'INTERNAL'
    if node.script != text:
        with _Compiling():  # with Cycles as engine, assigning compiles too
            node.script = text
    compile_script_node(node)
    return node
