# SPDX-License-Identifier: GPL-3.0-or-later
"""The extension's core: what needs neither Blender nor a renderer.

- :mod:`.catalogue`: the models, their parameters, units, ranges, presets;
- :mod:`.validation`: checking parameters against it;
- :mod:`.variants`: node-group variants (names, sockets, width modes);
- :mod:`.reference`: the numpy reference, the judge;
- :mod:`.formulas`: the renderer-side description of each model, from which
  the OSL shaders and the native node graphs are generated;
- :mod:`.fits`: generated data (series coefficients, fitted closure mixtures).

Imports stay inside this package (standard library and numpy only); a test
checks it.
"""
