# SPDX-License-Identifier: GPL-3.0-or-later
"""Developer tools: packaging, the bpy process environment, demo and bench.

Run them as modules from the repository root, e.g. ``python -m tools.build_zip``.
"""
