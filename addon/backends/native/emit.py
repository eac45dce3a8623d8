# SPDX-License-Identifier: GPL-3.0-or-later
"""Native node graphs from expression graphs (:mod:`addon.core.formulas.expr`).

:func:`plan` turns the graphs of some named outputs into a list of
:class:`Node` records (a Blender node type, its properties, what feeds each
input) that :mod:`.build` instantiates in a node tree.  Pure Python, no
Blender: the plan is what the tests count and inspect.

Every operation maps to Cycles' SVM and EEVEE's GPU nodes with the graphs'
semantics (those of the Math node: safe division, square root, logarithm
and power); the few that have no node are composed:

- ``select(c, a, b)`` = a c + b (1 - c), exact for c in {0, 1} and finite
  a, b (the formulas guard every value); a c alone where b is 0, b (1 - c)
  where a is 0;
- ``clamp_input(x, lo, hi)`` = min(max(x, lo), hi): Math MAXIMUM is fmaxf,
  which maps NaN to the other operand, so NaN goes to ``lo`` as in OSL;
- ``finite(x)`` = (x > -FLT_MAX) (x < FLT_MAX): a comparison with NaN is 0;
- ``table(values, t)``: a Float Curve node whose points are the values with
  vector handles (straight segments), sampled by Blender into a 256-entry
  table: between the table's samples a knot's kink is cut by at most a
  quarter of the change of slope times 1/255;
- ``occluded``: the Raycast node (Blender 5.x) from the position lifted by
  1e-4 along the true normal, to the side the ray leaves on (without it,
  false self-hits on a quad's diagonal, and on the face itself for a light
  behind it); in Blender 4.5, which has no Raycast node, nothing is
  occluded;
- ``engine_switch(cycles, eevee)``: a Mix Shader whose factor is the Alpha
  of Shader to RGB of an emission through a Maximum (1 in EEVEE; Cycles
  drops the node and the Maximum's input keeps its socket's value, 0);
- closures: Diffuse, Toon (glossy), Glossy (GGX, Beckmann, Ashikhmin-Shirley; roughness
  sqrt(alpha), anisotropy from the ratio), Hair (reflection) with their
  colour as the weight; the Metallic BSDF (physical conductor) has no colour
  input, so its weight is a Mix Shader, and a coloured weight takes one
  closure per channel (the others get n = 1, k = 0, where F = 0); a
  dielectric is a conductor of k = 0, but in Blender 4.5 (an older
  conductor Fresnel) a GGX lobe is the Principled BSDF's specular layer (one
  per channel where the index differs by channel), exact, its weight's
  colour the tint of a coat of index 1; 4.5's other Metallic BSDFs have
  their weight multiplied by the exact Fresnel over 4.5's at the view
  (:func:`older_fresnel_factor`: exact at the lobe's mirror direction).
"""

from __future__ import annotations

from dataclasses import dataclass, field

from ...core.formulas import expr as E
from ...core.formulas import library as L

FLT_MAX = 3.4028234663852886e38
RAY_OFFSET = 1e-4


def _is_zero(e) -> bool:
    """A constant 0 (a float, or a vector of three zeros)."""
    if e.op == "const":
        return e.data == 0.0
    if e.op == "vlit":
        return all(x == 0.0 for x in e.data)
    if e.op == "vec":
        return all(_is_zero(x) for x in e.args)
    return False


@dataclass
class Node:
    """One node: ``inputs`` maps an input (index or name) to a source:
    ``("const", value)``, ``("link", node id, output)``, ``("group", name)``
    (an input of the graph) or ``("geometry", name)``."""
    id: str
    type: str
    props: dict = field(default_factory=dict)
    inputs: dict = field(default_factory=dict)
    label: str = ""
    depth: int = 0


MATH = {"add": "ADD", "sub": "SUBTRACT", "mul": "MULTIPLY", "div": "DIVIDE", "pow": "POWER",
        "min": "MINIMUM", "max": "MAXIMUM", "atan2": "ARCTAN2", "gt": "GREATER_THAN",
        "lt": "LESS_THAN"}
MATH1 = {"sqrt": "SQRT", "exp": "EXPONENT", "sin": "SINE", "cos": "COSINE", "tan": "TANGENT",
         "atan": "ARCTANGENT", "abs": "ABSOLUTE", "floor": "FLOOR"}
VMATH = {"vadd": "ADD", "vsub": "SUBTRACT", "vmul": "MULTIPLY", "vdiv": "DIVIDE"}
GLOSSY = {"ggx": "GGX", "beckmann": "BECKMANN"}


class Planner:
    def __init__(self, raycast: bool = True, exact_conductor: bool = True):
        self.raycast = raycast
        self.exact_conductor = exact_conductor
        self.nodes: list[Node] = []
        self.memo: dict = {}
        self.separate: dict = {}

    # -- helpers ----------------------------------------------------------------
    def add(self, type_, props=None, inputs=None, label="", depth=0):
        node = Node(f"n{len(self.nodes)}", type_, dict(props or {}), dict(inputs or {}), label,
                    depth)
        self.nodes.append(node)
        return node

    def depth(self, *sources):
        d = 0
        for s in sources:
            if s[0] == "link":
                d = max(d, self._by_id[s[1]].depth + 1)
        return d

    def math(self, op, *srcs):
        n = self.add("ShaderNodeMath", {"operation": op},
                     {i: s for i, s in enumerate(srcs)}, depth=self.depth(*srcs))
        self._by_id[n.id] = n
        return ("link", n.id, 0)

    def vmath(self, op, *srcs, scale=None):
        inputs = {i: s for i, s in enumerate(srcs)}
        if scale is not None:
            inputs[3] = scale
        n = self.add("ShaderNodeVectorMath", {"operation": op}, inputs,
                     depth=self.depth(*srcs, *(() if scale is None else (scale,))))
        self._by_id[n.id] = n
        out = 1 if op in ("DOT_PRODUCT", "LENGTH", "DISTANCE") else 0
        return ("link", n.id, out)

    def node(self, type_, props, inputs, out=0, label=""):
        n = self.add(type_, props, inputs, label, depth=self.depth(*inputs.values()))
        self._by_id[n.id] = n
        return ("link", n.id, out)

    # -- the graph ----------------------------------------------------------------
    def run(self, outputs: dict) -> dict:
        self._by_id = {}
        self._fused = self._fusable(outputs.values())
        refs = {}
        for name, expr in outputs.items():
            refs[name] = self.ref(expr)
        return refs

    @staticmethod
    def _fusable(roots) -> set:
        """Products used once, by a sum: the sum becomes one Multiply Add
        node (Math or Vector Math) and the product no node of its own."""
        uses = {}
        order = E.topological(list(roots))
        for node in order:
            for a in node.args:
                uses[id(a)] = uses.get(id(a), 0) + 1
        for r in roots:
            uses[id(r)] = uses.get(id(r), 0) + 2  # an output is a use of its own
        fused = set()
        for node in order:
            if node.op not in ("add", "vadd"):
                continue
            for a in node.args:
                if a.op == ("mul" if node.op == "add" else "vscale") and uses[id(a)] == 1:
                    fused.add(id(a))
                    break
        return fused

    def ref(self, e):
        key = id(e)
        if key in self.memo:
            return self.memo[key]
        for node in E.topological([e]):  # depth-first without recursion limits
            if id(node) not in self.memo:
                self.memo[id(node)] = self._emit(node)
        return self.memo[key]

    def _r(self, e):
        return self.memo[id(e)]

    def _emit(self, e):
        op, a = e.op, e.args
        if op == "const":
            return ("const", e.data)
        if op == "vlit":
            return ("const", e.data)
        if op == "input":
            name, source = e.data
            return ("geometry", name) if source == "geometry" else ("group", name)
        if op in ("vec", "pack"):
            if all(x.op == "const" for x in a):
                return ("const", tuple(x.data for x in a))
            return self.node("ShaderNodeCombineXYZ", {}, {i: self._r(x) for i, x in enumerate(a)})
        if op == "comp":
            src = self._r(a[0])
            if src[0] == "const":
                return ("const", src[1][e.data])
            key = src
            if key not in self.separate:
                self.separate[key] = self.node("ShaderNodeSeparateXYZ", {}, {0: src})
            sep = self.separate[key]
            return ("link", sep[1], e.data)
        if id(e) in self._fused:  # made by the sum that uses it
            return ("fused", e)
        if op in ("add", "vadd"):
            fused = [x for x in a if self._r(x)[0] == "fused"]
            if fused:
                (p, q), other = fused[0].args, a[1] if a[0] is fused[0] else a[0]
                if op == "add":
                    return self.math("MULTIPLY_ADD", self._r(p), self._r(q), self._r(other))
                return self.vmath("MULTIPLY_ADD", self._r(p), self._splat(self._r(q)),
                                  self._r(other))
        if op in MATH:
            return self.math(MATH[op], *(self._r(x) for x in a))
        if op in MATH1:
            return self.math(MATH1[op], self._r(a[0]))
        if op == "neg":
            return self.math("MULTIPLY", self._r(a[0]), ("const", -1.0))
        if op == "log":  # natural logarithm: base e (logf(e) rounds to 1 in float32)
            return self.math("LOGARITHM", self._r(a[0]), ("const", 2.718281828459045))
        if op == "select":
            c, x, y = (self._r(v) for v in a)
            if e.kind == "f" and _is_zero(a[2]):  # a c + 0 (1 - c): one node
                return self.math("MULTIPLY", x, c)
            if e.kind == "v" and _is_zero(a[2]):
                return self.vmath("SCALE", x, scale=c)
            notc = self.math("SUBTRACT", ("const", 1.0), c)
            if e.kind == "f" and _is_zero(a[1]):
                return self.math("MULTIPLY", y, notc)
            if e.kind == "v":
                return self.vmath("ADD", self.vmath("SCALE", x, scale=c),
                                  self.vmath("SCALE", y, scale=notc))
            if e.kind == "c":
                raise ValueError("a choice between closures has no native form: build one "
                                 "branch (the variant is known)")
            return self.math("MULTIPLY_ADD", y, notc, self.math("MULTIPLY", x, c))
        if op == "clamp_input":
            lo, hi = e.data
            return self.math("MINIMUM", self.math("MAXIMUM", self._r(a[0]), ("const", lo)),
                             ("const", hi))
        if op == "table":
            src = self._r(a[0])
            key = ("table_input", src)  # one clamp for the tables of one variable
            if key not in self.separate:
                self.separate[key] = self.math(
                    "MINIMUM", self.math("MAXIMUM", src, ("const", 0.0)), ("const", 1.0))
            t = self.separate[key]
            return self.node("ShaderNodeFloatCurve", {"curve": e.data},
                             {"Factor": ("const", 1.0), "Value": t})
        if op == "finite":
            x = self._r(a[0])
            return self.math("MULTIPLY", self.math("GREATER_THAN", x, ("const", -FLT_MAX)),
                             self.math("LESS_THAN", x, ("const", FLT_MAX)))
        if op in VMATH:
            return self.vmath(VMATH[op], self._r(a[0]), self._r(a[1]))
        if op == "vscale":
            return self.vmath("SCALE", self._r(a[0]), scale=self._r(a[1]))
        if op == "dot":
            return self.vmath("DOT_PRODUCT", self._r(a[0]), self._r(a[1]))
        if op == "reflect":
            return self.vmath("REFLECT", self._r(a[0]), self._r(a[1]))
        if op == "cross":
            return self.vmath("CROSS_PRODUCT", self._r(a[0]), self._r(a[1]))
        if op == "length":
            return self.vmath("LENGTH", self._r(a[0]))
        if op == "normalize":
            return self.vmath("NORMALIZE", self._r(a[0]))
        if op == "occluded":
            if not self.raycast:
                return ("const", 0.0)
            P, d, length, enabled = (self._r(x) for x in a)
            # lifted off the surface on the light's side: a ray toward a
            # light behind the surface (fibres are lit from there) must not
            # hit its own face, which OSL's trace() skips
            side = self.math("GREATER_THAN", self.vmath("DOT_PRODUCT", ("geometry", "Ng"), d),
                             ("const", 0.0))
            offset = self.math("MULTIPLY_ADD", side, ("const", 2.0 * RAY_OFFSET),
                               ("const", -RAY_OFFSET))
            start = self.vmath("MULTIPLY_ADD", ("geometry", "Ng"), self._splat(offset), P)
            hit = self.node("ShaderNodeRaycast", {},
                            {"Position": start, "Direction": d,
                             "Length": self.math("MULTIPLY", length, enabled)}, out="Is Hit")
            return hit
        if op == "closure":
            return self._closure(e)
        if op == "closure_sum":
            refs = [self._r(x) for x in a]
            if not refs:
                return None
            acc = refs[0]
            for r in refs[1:]:
                acc = self.node("ShaderNodeAddShader", {}, {0: acc, 1: r})
            return acc
        if op == "engine_switch":
            return self._engine_switch(*(self._r(x) for x in a))
        if op == "choose":
            raise ValueError("choose() reached the native backend: the variant must be known")
        raise ValueError(f"no native form for {op!r}")

    def _splat(self, f):
        """A float as a vector (x, x, x), one node per float."""
        if f[0] == "const":
            return ("const", (f[1],) * 3)
        key = ("splat", f)
        if key not in self.separate:
            self.separate[key] = self.node("ShaderNodeCombineXYZ", {}, {0: f, 1: f, 2: f})
        return self.separate[key]

    def _engine_switch(self, cycles, eevee, both=("const", 0.0)):
        """A Mix Shader: its factor is the larger of the Alpha of Shader to
        RGB of a white emission, 1 in EEVEE, and ``both`` (1 where Cycles
        renders ``eevee`` too); Cycles has no Shader to RGB node, drops the
        link and leaves the Maximum's input at its socket's value, set to 0
        here (measured in Cycles SVM and EEVEE, Blender 4.5, 5.2 and 5.3).  The
        Math node is there even where ``both`` is 0: Blender 5.3.0's EEVEE
        crashes (a segmentation fault) on a Mix Shader whose factor is a
        Shader to RGB's output itself with an Add Shader on one of its
        inputs, and renders it with a Math node between (measured)."""
        probe = self.node("ShaderNodeEmission", {}, {"Color": ("const", (1.0, 1.0, 1.0)),
                                                     "Strength": ("const", 1.0)})
        is_eevee = self.node("ShaderNodeShaderToRGB", {}, {0: probe}, out=1)
        fac = self.node("ShaderNodeMath", {"operation": "MAXIMUM", "input_defaults": {0: 0.0}},
                        {0: is_eevee, 1: both})
        return self.node("ShaderNodeMixShader", {"input_defaults": {0: 0.0}},
                         {0: fac, 1: cycles, 2: eevee}, label="Cycles | EEVEE")

    # -- closures -----------------------------------------------------------------
    def _roughness(self, ax, ay):
        """Cycles' Glossy: roughness r (alpha = r^2, isotropic alpha =
        sqrt(ax ay)) and anisotropy a: ax = alpha (1 - a), ay = alpha/(1 - a)
        for a > 0; ax = alpha/(1 + a), ay = alpha (1 + a) for a < 0."""
        r = self.math("SQRT", self.math("SQRT", self.math("MULTIPLY", ax, ay)))
        ratio = self.math("SQRT", self.math("DIVIDE", ax, ay))  # sqrt(ax/ay)
        inv = self.math("SQRT", self.math("DIVIDE", ay, ax))
        pos = self.math("SUBTRACT", ("const", 1.0), ratio)      # ax <= ay
        neg = self.math("SUBTRACT", inv, ("const", 1.0))        # ax > ay
        c = self.math("GREATER_THAN", ax, ay)
        aniso = self.math("MULTIPLY_ADD", neg, c,
                          self.math("MULTIPLY", pos, self.math("SUBTRACT", ("const", 1.0), c)))
        return r, aniso

    def _closure(self, e):
        name, params = e.data
        params = dict(params)
        w = self._r(e.args[0])
        # one expression for both widths: isotropic, with no anisotropy and
        # no tangent (nothing of the frame's tangent computed for it)
        isotropic = name in ("microfacet", "ashikhmin_shirley", "conductor", "dielectric") \
            and e.args[3] is e.args[4]
        args = [None if isotropic and i == 1 else self._r(x) for i, x in enumerate(e.args[1:])]
        if name == "diffuse":
            return self.node("ShaderNodeBsdfDiffuse", {}, {"Color": w, "Normal": args[0]})
        if name == "glossy_toon":
            n, size, smooth = args
            return self.node("ShaderNodeBsdfToon", {"component": "GLOSSY"},
                             {"Color": w, "Size": size, "Smooth": smooth, "Normal": n})
        if name in ("microfacet", "ashikhmin_shirley"):
            n, t, ax, ay = args
            dist = "ASHIKHMIN_SHIRLEY" if name == "ashikhmin_shirley" else \
                GLOSSY[params["distribution"]]
            if isotropic:  # roughness sqrt(alpha)
                return self.node("ShaderNodeBsdfGlossy", {"distribution": dist},
                                 {"Color": w, "Roughness": self.math("SQRT", ax), "Normal": n})
            r, aniso = self._roughness(ax, ay)
            return self.node("ShaderNodeBsdfGlossy", {"distribution": dist},
                             {"Color": w, "Roughness": r, "Anisotropy": aniso, "Normal": n,
                              "Tangent": t})
        if name == "hair_reflection":
            n, ru, rv, t, offset = args
            return self.node("ShaderNodeBsdfHair", {"component": "Reflection"},
                             {"Color": w, "RoughnessU": ru, "RoughnessV": rv, "Tangent": t,
                              "Offset": offset})
        if name in ("conductor", "dielectric"):
            if name == "conductor":
                n, t, ax, ay, ior, k = args
            else:  # a dielectric is a conductor of extinction 0 (F at total internal reflection: 1)
                n, t, ax, ay, ior = args
                ior = self.node("ShaderNodeCombineXYZ", {}, {0: ior, 1: ior, 2: ior})
                k = ("const", (0.0, 0.0, 0.0))
            return self._metallic(w, n, None if isotropic else t, ax, ay, ior, k,
                                  GLOSSY[params["distribution"]],
                                  lambda: self.ref(older_fresnel_factor(e)))
        raise ValueError(f"no native closure {name!r}")

    @staticmethod
    def _grey(w):
        """The value of a weight that is one constant grey, else None."""
        if w[0] == "const" and isinstance(w[1], tuple) and len(set(w[1])) == 1:
            return ("const", w[1][0])
        return None

    def _principled_dielectric(self, w, n, shape, ior, scaled, channel=None):
        """Where the Metallic BSDF's conductor Fresnel is an older
        approximation (4.5: 2.1 of the peak off for a dielectric, k = 0,
        measured), a GGX lobe with a dielectric's Fresnel of one real index
        is the Principled BSDF's specular layer: base colour black, GGX
        (single scattering), Specular IOR Level 0.5 (the index's own
        Fresnel, exact: 5.7e-6 of the peak measured in 4.5.15), IOR
        ``ior``, one number; its Anisotropic and Anisotropic Rotation are
        the Metallic BSDF's Anisotropy and Rotation.  Weighted by ``scaled``
        (a Mix Shader) with the largest channel of ``w``; a coloured ``w``
        is the tint of a coat of index 1 (which reflects nothing), whose
        tint t Cycles applies to the layers under it as t^(1/|cos|), |cos|
        its normal's with the view: a tint of (w / max w)^|N.I| is
        w / max w (2.3e-5 of the peak measured in 4.5.15, colours
        (0.9, 0.5, 0.2), (0.2, 1, 0.05), (0.7, 0.7, 0.3), views to 75 deg).
        ``channel`` (0, 1 or 2): the lobe of that channel only, weighted by
        ``w`` there (a scalar), its coat's tint that channel's unit colour
        (1^x = 1, 0^x = 0): an index per channel is three such lobes."""
        names = {"Anisotropy": "Anisotropic", "Rotation": "Anisotropic Rotation"}
        inputs = {names.get(key, key): value for key, value in shape.items()}
        size, tint = (w, ("const", tuple(float(i == channel) for i in range(3)))) \
            if channel is not None else (self._grey(w), None)
        if size is None:
            sep = self.node("ShaderNodeSeparateXYZ", {}, {0: w})
            channels = [("link", sep[1], i) for i in range(3)]
            size = self.math("MAXIMUM", self.math("MAXIMUM", channels[0], channels[1]),
                             channels[2])
            cos = self.math("ABSOLUTE", self.vmath("DOT_PRODUCT", n, ("geometry", "I")))
            tint = self.node("ShaderNodeCombineXYZ", {}, {
                i: self.math("POWER", self.math("DIVIDE", c, size), cos)
                for i, c in enumerate(channels)})
        if tint is not None:
            inputs.update({"Coat Weight": ("const", 1.0), "Coat IOR": ("const", 1.0),
                           "Coat Tint": tint, "Coat Normal": n})
        shader = self.node("ShaderNodeBsdfPrincipled", {"distribution": "GGX"},
                           {"Base Color": ("const", (0.0, 0.0, 0.0)),
                            "Metallic": ("const", 0.0), "Specular IOR Level": ("const", 0.5),
                            "IOR": ior, **inputs})
        return scaled(shader, size)

    def _metallic(self, w, n, t, ax, ay, ior, k, dist, older_factor=None):
        """Metallic BSDF (physical conductor): roughness sqrt(sqrt(ax ay)),
        anisotropy 1 - (small/large)/0.9 ... clamped to a ratio of 10, and a
        quarter turn of the tangent when ax < ay (its anisotropy only
        stretches along the tangent).  Weighted by Mix Shaders: the grey
        part of the weight on one closure, what each channel has beyond it on
        a closure of that channel only.  Where this Blender's conductor
        Fresnel is an older approximation (4.5), a dielectric's GGX lobe is
        :meth:`_principled_dielectric` instead (one lobe where the index's
        three channels are equal, else one per channel), and the Metallic
        BSDF's weight takes ``older_factor()`` as a factor (the closure's
        :func:`older_fresnel_factor`, planned only there)."""
        corr = None  # the factor of every channel's weight, where there is one
        if t is None:  # isotropic (``ax`` is ``ay``): no anisotropy, no tangent
            shape = {"Roughness": self.math("SQRT", ax), "Normal": n}
        else:
            r = self.math("SQRT", self.math("SQRT", self.math("MULTIPLY", ax, ay)))
            small = self.math("MINIMUM", ax, ay)
            large = self.math("MAXIMUM", ax, ay)
            aniso = self.math("DIVIDE", self.math("SUBTRACT", ("const", 1.0),
                                                  self.math("DIVIDE", small, large)),
                              ("const", 0.9))
            rot = self.math("MULTIPLY", self.math("LESS_THAN", ax, ay), ("const", 0.25))
            shape = {"Roughness": r, "Anisotropy": aniso, "Rotation": rot, "Normal": n,
                     "Tangent": t}

        def metal(ior_, k_):
            return self.node("ShaderNodeBsdfMetallic",
                             {"distribution": dist, "fresnel_type": "PHYSICAL_CONDUCTOR"},
                             {"IOR": ior_, "Extinction": k_, **shape})

        def scaled(shader, s):
            if corr is not None:
                s = self.math("MULTIPLY", s, corr)
            fac = self.math("SUBTRACT", ("const", 1.0), s)  # Mix Shader clamps its factor
            return self.node("ShaderNodeMixShader", {}, {0: fac, 1: shader})

        def metallic():
            """The Metallic BSDF's lobes: the grey part of the weight on one,
            each channel's excess over it on one of that channel only."""
            if self._grey(w) is not None:
                return scaled(metal(ior, k), self._grey(w))
            sep = self.node("ShaderNodeSeparateXYZ", {}, {0: w})
            wr, wg, wb = (("link", sep[1], i) for i in range(3))
            grey = self.math("MINIMUM", self.math("MINIMUM", wr, wg), wb)
            total = scaled(metal(ior, k), grey)
            isep = self.node("ShaderNodeSeparateXYZ", {}, {0: ior})
            ksep = self.node("ShaderNodeSeparateXYZ", {}, {0: k})
            for i, wc in enumerate((wr, wg, wb)):
                only_ior = {j: (("link", isep[1], i) if j == i else ("const", 1.0))
                            for j in range(3)}
                only_k = {j: (("link", ksep[1], i) if j == i else ("const", 0.0))
                          for j in range(3)}
                one = metal(self.node("ShaderNodeCombineXYZ", {}, only_ior),
                            self.node("ShaderNodeCombineXYZ", {}, only_k))
                part = scaled(one, self.math("SUBTRACT", wc, grey))
                total = self.node("ShaderNodeAddShader", {}, {0: total, 1: part})
            return total

        dielectric = k[0] == "const" and not any(k[1] if isinstance(k[1], tuple) else (k[1],))
        if self.exact_conductor:
            return metallic()
        if not dielectric or dist != "GGX":  # 4.5's conductor Fresnel: the weight corrected
            corr = older_factor() if older_factor is not None else None
            return metallic()
        # the Principled BSDF's exact dielectric lobe: one where the three channels have
        # one index, else one lobe per channel (three closures)
        isep = self.node("ShaderNodeSeparateXYZ", {}, {0: ior})
        indices = [("link", isep[1], i) for i in range(3)]
        ir, ig, ib = indices
        same = self.math("MULTIPLY", self.node("ShaderNodeMath", {"operation": "COMPARE"},
                                               {0: ir, 1: ig, 2: ("const", 0.0)}),
                         self.node("ShaderNodeMath", {"operation": "COMPARE"},
                                   {0: ig, 1: ib, 2: ("const", 0.0)}))
        if self._grey(w) is not None:
            weights = [self._grey(w)] * 3
        else:
            wsep = self.node("ShaderNodeSeparateXYZ", {}, {0: w})
            weights = [("link", wsep[1], i) for i in range(3)]
        per_channel = None
        for c in range(3):
            lobe = self._principled_dielectric(weights[c], n, shape, indices[c], scaled, c)
            per_channel = lobe if per_channel is None else \
                self.node("ShaderNodeAddShader", {}, {0: per_channel, 1: lobe})
        return self.node("ShaderNodeMixShader", {},
                         {0: same, 1: per_channel,
                          2: self._principled_dielectric(w, n, shape, ir, scaled)})


def older_conductor_fresnel(c, eta, k):
    """Blender 4.5's conductor Fresnel, an approximation (Cycles 4.5's
    ``fresnel_conductor``, read in its kernel, not copied; it matches the
    renders of docs/cycles-closures.md): the mean of
    (a c^2 - 2 eta c + 1)/(a c^2 + 2 eta c + 1) and
    (a - 2 eta c + c^2)/(a + 2 eta c + c^2), a = eta^2 + k^2, here as
    ((eta c -+ 1)^2 + (k c)^2) and ((eta -+ c)^2 + k^2): the same numbers,
    without float32 cancelling them to 0 where eta is near 1 and k near 0."""
    kc2, k2 = (k * c) * (k * c), k * k
    return 0.5 * (E.div((eta * c - 1.0) * (eta * c - 1.0) + kc2,
                        (eta * c + 1.0) * (eta * c + 1.0) + kc2)
                  + E.div((eta - c) * (eta - c) + k2, (eta + c) * (eta + c) + k2))


def older_fresnel_factor(e):
    """What the weight of a conductor (or dielectric) closure ``e`` is
    multiplied by on a Metallic BSDF whose Fresnel is Blender 4.5's
    approximation: per channel, the exact Fresnel over the approximation,
    both at the view's cosine with the closure's normal (Cycles takes F at
    the half vector, which is the normal at the mirror direction, where the
    lobe peaks).  The closure has no colour input, so one factor serves the
    three channels: the channels' ratio where they agree (a dielectric's
    one index), else the one nearest 1 on the side where they all lie (1
    where they lie on both), so that at the mirror direction no channel's
    Fresnel is further off than without it."""
    normal, ior = e.args[1], e.args[5]
    k = e.args[6] if e.data[0] == "conductor" else 0.0
    c = E.clamp(E.dot(normal, E.geometry("I")), 0.0, 1.0)

    def ratio_of(c_, eta, k_):
        # k = 0: the dielectric's form (the same number; the conductor's
        # cancels to 0 in float32 where the index is near 1)
        exact = E.select(E.gt(k_, 0.0), L.F_conductor(c_, eta, k_), L.F_dielectric(c_, eta))
        return E.div(exact, older_conductor_fresnel(c_, eta, k_))
    ratio = L.per_channel(ratio_of, c, ior, k)
    r = [ratio[i] for i in range(3)]
    if r[0] is r[1] is r[2]:
        return r[0]
    low, high = E.fmin(E.fmin(r[0], r[1]), r[2]), E.fmax(E.fmax(r[0], r[1]), r[2])
    return E.fmax(low, E.fmin(high, 1.0))


def plan(outputs: dict, *, raycast: bool = True, exact_conductor: bool = True):
    """``(nodes, refs)``: the node plan of ``outputs`` (name -> Expr) and
    each output's source (``raycast``: whether the Blender that builds it
    has the Raycast node; ``exact_conductor``: whether its Metallic BSDF's
    physical conductor has the exact Fresnel; see :mod:`.build`)."""
    p = Planner(raycast=raycast, exact_conductor=exact_conductor)
    refs = p.run(outputs)
    return _reachable(p.nodes, refs.values()), refs


def _reachable(nodes, sources):
    """The nodes some output depends on, in their order (an expression is
    planned whole before the node that uses it: an isotropic closure's
    tangent, which it does not link, leaves nodes nothing reads)."""
    by_id = {n.id: n for n in nodes}
    keep = set()
    stack = [s[1] for s in sources if s is not None and s[0] == "link"]
    while stack:
        i = stack.pop()
        if i in keep:
            continue
        keep.add(i)
        stack += [src[1] for src in by_id[i].inputs.values() if src[0] == "link"]
    return [n for n in nodes if n.id in keep]


def count(outputs: dict, **caps) -> int:
    return len(plan(outputs, **caps)[0])
