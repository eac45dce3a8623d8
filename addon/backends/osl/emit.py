# SPDX-License-Identifier: GPL-3.0-or-later
"""OSL source from expression graphs (:mod:`addon.core.formulas.expr`).

:func:`statements` turns the graphs of some named outputs into OSL
statements: every shared or branch-local subexpression becomes a local
variable, a ``choose`` becomes an ``if`` chain on the shader's int
parameter (OSL's runtime optimiser folds it when the int is constant, as it
is in a node group), and nodes used by one branch only are computed inside
that branch.  The safe arithmetic of the graphs (``rm_div``, ``rm_sqrt``,
...) is in ``rm_library.h``.

Pure Python; no Blender.
"""

from __future__ import annotations

import math

from ...core.formulas import expr as E

GEOMETRY = {"N": "N", "I": "rm_view()", "P": "P", "uv_tangent": "default_tangent"}
_TYPES = {"f": "float", "v": "vector", "c": "closure color"}


def number(x: float) -> str:
    """An OSL float literal."""
    if not math.isfinite(x):
        raise ValueError(f"not a finite constant: {x!r}")
    text = repr(float(x))
    if "e" in text and "." not in text.split("e")[0]:
        mant, ex = text.split("e")
        text = f"{mant}.0e{ex}"
    elif "." not in text and "e" not in text:
        text += ".0"
    return text


CLOSURES = {
    # name -> template over the arguments after the weight; {d} = distribution
    "diffuse": "diffuse({0})",
    "phong_ramp": "rm_phong_ramp({0}, {1})",
    "microfacet": 'microfacet("{d}", {0}, {1}, {2}, {3}, 0.0, 0)',
    "dielectric": 'dielectric_bsdf({0}, {1}, color(1.0), color(0.0), {2}, {3}, {4}, "{d}")',
    "conductor": 'conductor_bsdf({0}, {1}, {2}, {3}, {4}, {5}, "{d}")',
    "hair_reflection": "hair_reflection({0}, {1}, {2}, {3}, {4})",
    "ashikhmin_shirley": 'microfacet("ashikhmin_shirley", {0}, {1}, {2}, {3}, 0.0, 0)',
}
DISTRIBUTIONS = {"ggx", "beckmann"}  # any other string silently renders GGX in Cycles


def _branches(node, i) -> bool:
    """Whether argument ``i`` of ``node`` is evaluated only in its branch: the
    branches of a choose, and of a select between closures (OSL has no
    ternary on closures, and a closure is built only where it is used)."""
    if node.op == "choose":
        return True
    return node.op == "select" and node.kind == "c" and i > 0


def _contexts(order, roots):
    """The context of every node: the branches (choose node, branch index)
    inside which all its uses lie (the longest common prefix)."""
    ctx = {id(r): () for r in roots}
    for node in reversed(order):
        here = ctx.get(id(node))
        if here is None:  # unreachable from roots (cannot happen)
            continue
        for i, arg in enumerate(node.args):
            use = here + ((id(node), i),) if _branches(node, i) else here
            old = ctx.get(id(arg))
            if old is None:
                ctx[id(arg)] = use
            else:
                k = 0
                while k < min(len(old), len(use)) and old[k] == use[k]:
                    k += 1
                ctx[id(arg)] = old[:k]
    return ctx


class _Emitter:
    def __init__(self, outputs: dict, enum_codes: dict):
        self.outputs = outputs
        self.enum_codes = enum_codes
        self.roots = list(outputs.values())
        self.order = E.topological(self.roots)
        self.index = {id(n): i for i, n in enumerate(self.order)}
        self.ctx = _contexts(self.order, self.roots)
        uses = {}
        for node in self.order:
            for a in node.args:
                uses[id(a)] = uses.get(id(a), 0) + 1
        for r in self.roots:
            uses[id(r)] = uses.get(id(r), 0) + 1
        self.uses = uses
        self.names = {}
        self.lines = []

    # -- expressions ----------------------------------------------------------
    def ref(self, node) -> str:
        if node.op == "const":
            return number(node.data)
        if node.op == "vlit":
            return f"vector({', '.join(number(x) for x in node.data)})"
        if node.op == "input":
            name, source = node.data
            return GEOMETRY[name] if source == "geometry" else name
        name = self.names.get(id(node))
        if name is not None:
            return name
        return "(" + self.expr(node) + ")"

    def inline(self, node) -> bool:
        """Single-use nodes are written into their user's expression."""
        return (node.op not in ("choose", "closure", "closure_sum", "table")
                and not (node.op == "select" and node.kind == "c")
                and self.uses.get(id(node), 0) == 1 and id(node) not in self._root_ids)

    def expr(self, n) -> str:
        a = [self.ref(x) for x in n.args]
        op = n.op
        infix = {"add": "+", "sub": "-", "mul": "*", "vadd": "+", "vsub": "-", "vmul": "*",
                 "vscale": "*"}
        if op in infix:
            return f"{a[0]} {infix[op]} {a[1]}"
        if op == "neg":
            return f"-{a[0]}"
        simple = {"div": "rm_div", "vdiv": "rm_div", "sqrt": "rm_sqrt", "log": "rm_log",
                  "pow": "rm_pow", "exp": "exp", "sin": "sin", "cos": "cos", "tan": "tan",
                  "atan": "atan", "atan2": "atan2", "abs": "abs", "floor": "floor",
                  "min": "min", "max": "max", "finite": "rm_finite", "dot": "dot",
                  "cross": "cross", "reflect": "reflect", "length": "length",
                  "normalize": "rm_normalize"}
        if op in simple:
            return f"{simple[op]}({', '.join(a)})"
        if op == "gt":
            return f"({a[0]} > {a[1]}) ? 1.0 : 0.0"
        if op == "lt":
            return f"({a[0]} < {a[1]}) ? 1.0 : 0.0"
        if op == "select":
            return f"({a[0]} != 0.0) ? {a[1]} : {a[2]}"
        if op == "clamp_input":
            lo, hi = n.data
            return f"rm_clamp({a[0]}, {number(lo)}, {number(hi)})"
        if op == "table":
            return f"rm_table({self.names[('table', id(n))]}, {a[0]})"
        if op in ("vec", "pack"):
            return f"vector({', '.join(a)})"
        if op == "comp":
            return f"{a[0]}[{n.data}]"
        if op == "occluded":
            return (f"({a[3]} != 0.0 && trace({a[0]}, {a[1]}, \"mindist\", 1e-5, "
                    f"\"maxdist\", {a[2]})) ? 1.0 : 0.0")
        if op == "closure":
            name, params = n.data
            params = dict(params)
            if name not in CLOSURES:
                raise ValueError(f"no OSL closure {name!r}")
            d = params.get("distribution", "")
            if name in ("microfacet", "dielectric", "conductor") and d not in DISTRIBUTIONS:
                raise ValueError(f"distribution {d!r} would silently render as GGX")
            return f"color({a[0]}) * " + CLOSURES[name].format(*a[1:], d=d)
        if op == "closure_sum":
            return " + ".join(a) if a else "0"
        raise ValueError(f"no OSL form for {op!r}")

    # -- statements -----------------------------------------------------------
    def emit(self):
        self._root_ids = {id(r) for r in self.roots}
        by_ctx = {}
        for node in self.order:
            if node.op in E.LEAVES:
                continue
            by_ctx.setdefault(self.ctx[id(node)], []).append(node)
        self.by_ctx = by_ctx
        self._block((), "    ")
        for name, node in self.outputs.items():
            self.lines.append(f"    {name} = {self.ref(node)};")
        return self.lines

    def _block(self, context, indent):
        for node in self.by_ctx.get(context, ()):
            if node.op == "choose":
                self._choose(node, context, indent)
            elif node.op == "select" and node.kind == "c":
                self._select_closure(node, context, indent)
            elif not self.inline(node):
                if node.op == "table":  # its knots as a constant array first
                    arr = f"_k{len(self.names)}"
                    self.names[("table", id(node))] = arr
                    self.lines.append(f"{indent}float {arr}[{len(node.data)}] = "
                                      f"{{{', '.join(number(x) for x in node.data)}}};")
                var = f"_{len(self.names)}"
                text = self.expr(node)
                self.names[id(node)] = var
                self.lines.append(f"{indent}{_TYPES[node.kind]} {var} = {text};")

    def _choose(self, node, context, indent):
        enum_name, keys = node.data
        codes = self.enum_codes[enum_name]
        var = f"_{len(self.names)}"
        self.names[id(node)] = var
        self.lines.append(f"{indent}{_TYPES[node.kind]} {var} = 0;" if node.kind == "c"
                          else f"{indent}{_TYPES[node.kind]} {var};")
        groups = []  # (branch indices, expression) with identical expressions merged
        for i, branch in enumerate(node.args):
            for g in groups:
                if g[1] is branch:
                    g[0].append(i)
                    break
            else:
                groups.append(([i], branch))
        for k, (idx, branch) in enumerate(groups):
            cond = " || ".join(f"{enum_name} == {codes[keys[i]]}" for i in idx)
            if k == 0:
                head = f"if ({cond}) {{"
            elif k == len(groups) - 1:
                head = f"else {{  // {' || '.join(keys[i] for i in idx)}"
            else:
                head = f"else if ({cond}) {{"
            self.lines.append(f"{indent}{head}")
            for i in idx:
                self._block(context + ((id(node), i),), indent + "    ")
            self.lines.append(f"{indent}    {var} = {self.ref(branch)};")
            self.lines.append(f"{indent}}}")


    def _select_closure(self, node, context, indent):
        var = f"_{len(self.names)}"
        self.names[id(node)] = var
        cond = self.ref(node.args[0])
        self.lines.append(f"{indent}closure color {var} = 0;")
        for k, head in ((1, f"if ({cond} != 0.0) {{"), (2, "else {")):
            self.lines.append(f"{indent}{head}")
            self._block(context + ((id(node), k),), indent + "    ")
            self.lines.append(f"{indent}    {var} = {self.ref(node.args[k])};")
            self.lines.append(f"{indent}}}")


def statements(outputs: dict, enum_codes: dict) -> list:
    """OSL statements (4-space indented) computing every graph of
    ``outputs`` (output name -> Expr) and assigning it to that name.
    ``enum_codes``: enum name -> {choice: int code}."""
    return _Emitter(outputs, enum_codes).emit()
