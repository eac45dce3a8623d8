# SPDX-License-Identifier: GPL-3.0-or-later
"""Regenerate the catalogue-driven documentation (``python -m tools.gen_docs``):
the README's model table and ``docs/models/<id>.md`` (see :mod:`report.docs`)."""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))


def main() -> int:
    from report import docs
    for path in docs.write():
        print(f"wrote {path.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
