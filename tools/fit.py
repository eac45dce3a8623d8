# SPDX-License-Identifier: GPL-3.0-or-later
"""Write the generated data of ``addon/core/fits`` (``python -m tools.fit``):
series coefficients computed in high precision (:mod:`fitting.series`)."""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))


def main(argv=None) -> int:
    from fitting import outputs
    for path, text in outputs().items():
        if not path.exists() or path.read_text() != text:
            path.write_text(text)
            print(f"wrote {path.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
