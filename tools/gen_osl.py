# SPDX-License-Identifier: GPL-3.0-or-later
"""Write the generated OSL shaders (``python -m tools.gen_osl``): see
:mod:`addon.backends.osl.generate`."""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))


def main() -> int:
    from addon.backends.osl import generate
    for path in generate.write():
        print(f"wrote {path.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
