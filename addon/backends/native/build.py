# SPDX-License-Identifier: GPL-3.0-or-later
"""The native backend in Blender: a node plan (:mod:`.emit`) made real in a
node tree, inside a frame, fed by the group's inputs and the shading
point's geometry.

Imports bpy inside the functions only.
"""

from __future__ import annotations

from . import emit

GEOMETRY_OUTPUTS = {"N": "Normal", "I": "Incoming", "P": "Position", "Ng": "True Normal"}
X_STEP, Y_STEP = 190.0, 150.0


def has_raycast() -> bool:
    """Whether this Blender has the Raycast shader node (5.x; not 4.5)."""
    import bpy
    return hasattr(bpy.types, "ShaderNodeRaycast")


def capabilities() -> dict:
    """The keyword arguments of :func:`.emit.plan` for this Blender."""
    return {"raycast": has_raycast()}


def set_constant(socket, value) -> None:
    """An unlinked socket's value: a float, or a vector/colour (a float
    fills every component; a colour's alpha is 1)."""
    current = socket.default_value
    if hasattr(current, "__len__"):
        vals = tuple(value) if isinstance(value, tuple) else (value,) * 3
        socket.default_value = vals + (1.0,) * (len(current) - len(vals))
    else:
        socket.default_value = value if not isinstance(value, tuple) else value[0]


def _socket(collection, key):
    if isinstance(key, int):
        return collection[key]
    for s in collection:
        if s.identifier == key or s.name == key:
            return s
    raise KeyError(key)


def _set_curve(node, values):
    """A Float Curve through ``values`` at evenly spaced x over [0, 1], with
    straight segments and no clipping."""
    mapping = node.mapping
    mapping.use_clip = False
    curve = mapping.curves[0]
    n = len(values)
    while len(curve.points) < n:
        curve.points.new(0.5, 0.0)
    while len(curve.points) > n:
        curve.points.remove(curve.points[-1])
    for i, (point, y) in enumerate(zip(curve.points, values)):
        point.location = (i / (n - 1), y)
        point.handle_type = "VECTOR"
    lo, hi = min(values), max(values)
    mapping.clip_min_x, mapping.clip_max_x = 0.0, 1.0
    mapping.clip_min_y, mapping.clip_max_y = lo - 1.0, hi + 1.0
    mapping.update()


class Builder:
    """Instantiates plans in ``tree`` under one frame.  ``group_input(name)``
    returns the output socket of the group's Group Input for a parameter;
    geometry nodes are made on first use."""

    def __init__(self, tree, group_input, *, origin=(0.0, -1200.0), label="Native nodes",
                 tangent=None):
        self.tree = tree
        self.group_input = group_input
        self.origin = origin
        self.frame = tree.nodes.new("NodeFrame")
        self.frame.label = label
        self.frame.name = "RM native"
        self._geometry = None
        self._tangent = tangent
        self.count = 0

    def geometry(self, name):
        if name == "uv_tangent":
            if self._tangent is None:
                t = self.tree.nodes.new("ShaderNodeTangent")
                t.direction_type = "UV_MAP"
                t.parent = self.frame
                t.location = (self.origin[0] - X_STEP, self.origin[1] - 200.0)
                self._tangent = t
            return self._tangent.outputs["Tangent"]
        if self._geometry is None:
            g = self.tree.nodes.new("ShaderNodeNewGeometry")
            g.parent = self.frame
            g.location = (self.origin[0] - X_STEP, self.origin[1])
            self._geometry = g
        return self._geometry.outputs[GEOMETRY_OUTPUTS[name]]

    def source(self, src, made):
        kind = src[0]
        if kind == "link":
            return _socket(made[src[1]].outputs, src[2])
        if kind == "group":
            return self.group_input(src[1])
        if kind == "geometry":
            return self.geometry(src[1])
        raise ValueError(src)

    def feed(self, socket, src, made):
        if src[0] == "const":
            set_constant(socket, src[1])
            return
        self.tree.links.new(self.source(src, made), socket)

    def instantiate(self, nodes, refs):
        """Make the plan's nodes; returns ``{output name: socket}`` (None for
        an empty closure sum; a constant stays ``("const", value)``)."""
        made = {}
        rows = {}
        for n in nodes:
            node = self.tree.nodes.new(n.type)
            # A name of our own at once: Blender names a new node "Math",
            # "Math.001", ... trying each suffix against every node, which
            # grows with the square of the tree; "Math" stays free this way.
            node.name = f"RM native {self.count + len(made)}"
            for prop, value in n.props.items():
                if prop == "curve":
                    _set_curve(node, value)
                elif prop == "input_defaults":  # kept where a link is dropped
                    for key, default in value.items():
                        set_constant(_socket(node.inputs, key), default)
                else:
                    setattr(node, prop, value)
            if n.label:
                node.label = n.label
            node.parent = self.frame
            row = rows.get(n.depth, 0)
            rows[n.depth] = row + 1
            node.location = (self.origin[0] + n.depth * X_STEP, self.origin[1] - row * Y_STEP)
            node.hide = True
            made[n.id] = node
        for n in nodes:
            node = made[n.id]
            for key, src in n.inputs.items():
                sock = _socket(node.inputs, key)
                if not sock.enabled and n.type == "ShaderNodeMath":
                    continue
                self.feed(sock, src, made)
        self.count += len(nodes)
        out = {}
        for name, src in refs.items():
            if src is None or src[0] == "const":
                out[name] = src
            else:
                out[name] = self.source(src, made)
        return out
