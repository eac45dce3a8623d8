# SPDX-License-Identifier: GPL-3.0-or-later
"""Build the extension zip (``python -m tools.build_zip``): see
:mod:`verification.harness.package`."""

from __future__ import annotations

import sys


def main() -> int:
    from verification.harness.package import ExtensionToolError, build_zip
    try:
        print(build_zip())
    except ExtensionToolError as exc:
        print(exc, file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
