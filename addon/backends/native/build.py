# SPDX-License-Identifier: GPL-3.0-or-later
"""The native backend in Blender: a node plan (:mod:`.emit`) made real in a
node tree, inside a frame (a large plan in nested groups of at most
PART_SIZE nodes), fed by the group's inputs and the shading point's
geometry.

Imports bpy inside the functions only.
"""

from __future__ import annotations

GEOMETRY_OUTPUTS = {"N": "Normal", "I": "Incoming", "P": "Position", "Ng": "True Normal"}
X_STEP, Y_STEP = 190.0, 150.0


def has_raycast() -> bool:
    """Whether this Blender has the Raycast shader node (5.x; not 4.5)."""
    import bpy
    return hasattr(bpy.types, "ShaderNodeRaycast")


def has_exact_conductor() -> bool:
    """Whether this Blender's Metallic BSDF (physical conductor) has the
    exact complex-index Fresnel (5.2; 4.5's is an older approximation:
    docs/compatibility.md)."""
    import bpy
    return tuple(bpy.app.version[:2]) >= (5, 2)


def capabilities() -> dict:
    """The keyword arguments of :func:`.emit.plan` for this Blender."""
    return {"raycast": has_raycast(), "exact_conductor": has_exact_conductor()}


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

    def _make(self, tree, n, made, rows, frame):
        """Node ``n`` of a plan in ``tree``, with its properties, named and
        placed by its depth (``frame``: its parent, or None)."""
        node = tree.nodes.new(n.type)
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
        if frame is not None:
            node.parent = frame
        row = rows.get(n.depth, 0)
        rows[n.depth] = row + 1
        node.location = (self.origin[0] + n.depth * X_STEP, self.origin[1] - row * Y_STEP)
        node.hide = True
        made[n.id] = node
        return node

    def instantiate(self, nodes, refs):
        """Make the plan's nodes; returns ``{output name: socket}`` (None for
        an empty closure sum; a constant stays ``("const", value)``).  A plan
        of more than PART_SIZE nodes is made in parts (:meth:`_in_parts`)."""
        if len(nodes) > PART_SIZE:
            return self._in_parts(nodes, refs)
        made = {}
        rows = {}
        for n in nodes:
            self._make(self.tree, n, made, rows, self.frame)
        for n in nodes:
            for sock, src in _fed(n, made[n.id]):
                self.feed(sock, src, made)
        self.count += len(nodes)
        return self._outputs(refs, made)

    def _outputs(self, refs, made, outside=None):
        """Each output's socket in the tree (None and constants as they are)."""
        return {name: src if src is None or src[0] == "const"
                else self._outer(src, made, outside) for name, src in refs.items()}

    def _outer(self, src, made, outside=None):
        """The socket of ``src`` in the tree: for a link, the output of the
        node's part where the plan is in parts (``outside``)."""
        if src[0] == "link" and outside is not None:
            return outside[(src[1], src[2])]
        return self.source(src, made)

    def _in_parts(self, nodes, refs):
        """The plan in nested node groups of at most PART_SIZE nodes each,
        in the plan's order (a node's sources before it).  Blender updates
        the whole tree at every node, link and value a script sets, so one
        tree of n nodes takes time growing with n squared to build (1,300
        nodes: 20 s); in parts, each update sees one part.  A part's inputs
        are the sources it takes from outside (the group's inputs, the
        geometry, earlier parts' outputs), each an interface socket of the
        source's type, linked in the group; its outputs are what later parts
        and the group's outputs take.  Renderers inline nested groups, so
        the graph rendered is the same; each part is built whole before its
        node is made in the group (an update of a used tree also updates
        its users)."""
        import bpy
        order = _topological(nodes)
        parts = [order[i:i + PART_SIZE] for i in range(0, len(order), PART_SIZE)]
        part_of = {n.id: k for k, part in enumerate(parts) for n in part}
        exported = {}  # node id -> its output keys read outside its part
        for src in [s for n in order for s in n.inputs.values()
                    if s[0] == "link" and part_of[s[1]] != part_of[n.id]] + \
                [s for s in refs.values() if s is not None and s[0] == "link"]:
            keys = exported.setdefault(src[1], [])
            if src[2] not in keys:
                keys.append(src[2])
        outside = {}  # (node id, output key) -> output socket of a part's node in the group
        made = {}
        base = self.tree.name[:40]
        for k, part in enumerate(parts):
            sub = bpy.data.node_groups.new(f".{base} part {k + 1}", "ShaderNodeTree")
            sub["rm_part"] = True
            sub_in = sub.nodes.new("NodeGroupInput")
            sub_out = sub.nodes.new("NodeGroupOutput")
            rows = {}
            for n in part:
                self._make(sub, n, made, rows, None)
            inputs = {}  # source key -> (interface identifier, socket in the group)
            for n in part:
                for sock, src in _fed(n, made[n.id]):
                    if src[0] == "const":
                        set_constant(sock, src[1])
                        continue
                    if src[0] == "link" and part_of[src[1]] == k:
                        sub.links.new(_socket(made[src[1]].outputs, src[2]), sock)
                        continue
                    skey = tuple(src)
                    if skey not in inputs:
                        outer = self._outer(src, made, outside)
                        item = sub.interface.new_socket(_port_name(src), in_out="INPUT",
                                                        socket_type=_socket_type(outer))
                        inputs[skey] = (item.identifier, outer)
                    sub.links.new(_socket(sub_in.outputs, inputs[skey][0]), sock)
            outputs = []
            for n in part:
                for okey in exported.get(n.id, ()):
                    inner = _socket(made[n.id].outputs, okey)
                    item = sub.interface.new_socket(_port_name(("link", n.id, okey)),
                                                    in_out="OUTPUT",
                                                    socket_type=_socket_type(inner))
                    sub.links.new(inner, _socket(sub_out.inputs, item.identifier))
                    outputs.append(((n.id, okey), item.identifier))
            sub_in.location = (self.origin[0] - X_STEP, self.origin[1])
            sub_out.location = (self.origin[0] + (max(rows) + 1) * X_STEP, self.origin[1])
            group = self.tree.nodes.new("ShaderNodeGroup")
            group.node_tree = sub
            group.name = f"RM native part {k + 1}"
            group.label = f"Native nodes, part {k + 1} of {len(parts)}"
            group.parent = self.frame
            group.location = (self.origin[0] + k * X_STEP, self.origin[1])
            group.hide = True
            for identifier, outer in inputs.values():
                self.tree.links.new(outer, _socket(group.inputs, identifier),
                                    verify_limits=False)
            for key, identifier in outputs:
                outside[key] = _socket(group.outputs, identifier)
        self.count += len(nodes)
        return self._outputs(refs, made, outside)


PART_SIZE = 150  # nodes of a plan per nested group (:meth:`Builder._in_parts`)

SOCKET_TYPES = {"VALUE": "NodeSocketFloat", "VECTOR": "NodeSocketVector",
                "RGBA": "NodeSocketColor", "SHADER": "NodeSocketShader",
                "INT": "NodeSocketInt", "BOOLEAN": "NodeSocketBool"}


def _fed(n, node):
    """``(input socket, source)`` for each input the plan's node ``n`` sets
    on ``node`` (a Math node's input its operation hides is left)."""
    for key, src in n.inputs.items():
        sock = _socket(node.inputs, key)
        if sock.enabled or n.type != "ShaderNodeMath":
            yield sock, src


def _socket_type(socket) -> str:
    """The interface socket type that carries ``socket``'s value unchanged."""
    try:
        return SOCKET_TYPES[socket.type]
    except KeyError:
        raise TypeError(f"no interface socket for a {socket.type} socket") from None


def _port_name(src) -> str:
    if src[0] == "link":
        return f"{src[1]} {src[2]}"
    return f"{src[0]} {src[1]}"


def _topological(nodes):
    """The plan's nodes with every node after the nodes it links from (the
    plan's own order where it already is)."""
    by_id = {n.id: n for n in nodes}
    done, order = set(), []
    for root in nodes:
        stack = [(root, False)]
        while stack:
            n, expanded = stack.pop()
            if n.id in done:
                continue
            if expanded:
                done.add(n.id)
                order.append(n)
                continue
            stack.append((n, True))
            for src in reversed(list(n.inputs.values())):
                if src[0] == "link" and src[1] not in done:
                    stack.append((by_id[src[1]], False))
    return order

