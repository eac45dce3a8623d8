# SPDX-License-Identifier: GPL-3.0-or-later
"""A small expression graph: the renderer-side description of the models.

Every model's evaluation (the exact radiance, its terms, its path-traced
closures) is written once as Python functions over :class:`Expr` nodes
(:mod:`.library`, :mod:`.models`); :mod:`addon.backends.osl.emit` turns a
graph into OSL source and :mod:`addon.backends.native.emit` into Blender
math nodes.  The numpy reference is *not* built from this: it is the judge.

Semantics every backend implements (they are those of Cycles' SVM Math
node, which OSL and EEVEE are made to match):

- values are float32 scalars (kind ``"f"``), 3-vectors or colours (``"v"``)
  and closures (``"c"``);
- ``div(a, 0) = 0``, ``sqrt(x < 0) = 0``, ``log(x <= 0) = 0``,
  ``pow(a, b)``: ``b == 0`` gives 1, ``a == 0`` gives 0, ``a < 0`` with a
  non-integer ``b`` gives 0;
- ``gt``/``lt`` give 1.0 or 0.0, ``select(c, a, b)`` takes ``c`` in {0, 1};
- ``clamp_input(x, lo, hi)`` maps NaN to ``lo`` (bad input renders like the
  range's limit), ``finite(x)`` is 1 unless ``x`` is NaN or infinite;
- ``table(values, t)``: linear interpolation between ``values`` at evenly
  spaced knots over t in [0, 1] (t clamped): an OSL constant array, a Float
  Curve node in native graphs (its 256-entry table);
- ``choose(enum, branches)`` picks a branch by a structural parameter: the
  native backend knows the variant and builds only its branch; the OSL
  backend receives the enum as an ``int`` and emits an ``if`` chain that
  OSL's optimiser folds.

Nodes are hash-consed: building the same expression twice gives the same
object, so common subexpressions are shared by construction.  Constant
subexpressions are folded in float64 when built.

Pure Python: no numpy, no bpy.
"""

from __future__ import annotations

import hashlib
import math

KINDS = ("f", "v", "c")
LEAVES = ("const", "vlit", "input")

# op -> (result kind rule, arity); "same" = kind of the first argument
_UNARY_F = {"neg", "sqrt", "exp", "log", "sin", "cos", "tan", "atan", "abs", "floor",
            "finite"}
_BINARY_F = {"add", "sub", "mul", "div", "pow", "min", "max", "atan2", "gt", "lt"}


class Expr:
    """One node of the graph.  Build with the functions of this module and
    Python operators, never with the constructor."""

    __slots__ = ("op", "args", "kind", "data", "skey", "__weakref__")

    def __init__(self, op, args, kind, data):
        self.op = op
        self.args = args
        self.kind = kind
        self.data = data
        # A structural key, the same in every process (Python's hash() of a
        # string is not): orders the arguments of commutative operations, so
        # the generated code does not depend on the order graphs were built.
        text = f"{op}|{kind}|{data!r}|" + ",".join(a.skey for a in args)
        self.skey = hashlib.blake2b(text.encode(), digest_size=10).hexdigest()

    # -- Python operators (floats are wrapped as constants) ------------------
    def __add__(self, other):
        return add(self, other)

    def __radd__(self, other):
        return add(other, self)

    def __sub__(self, other):
        return sub(self, other)

    def __rsub__(self, other):
        return sub(other, self)

    def __mul__(self, other):
        return mul(self, other)

    def __rmul__(self, other):
        return mul(other, self)

    def __truediv__(self, other):
        return div(self, other)

    def __rtruediv__(self, other):
        return div(other, self)

    def __neg__(self):
        return neg(self)

    def __getitem__(self, i):
        return comp(self, i)

    def __repr__(self):
        if self.op == "const":
            return f"const({self.data!r})"
        if self.op == "input":
            return f"input({self.data[0]!r})"
        return f"{self.op}({', '.join(map(repr, self.args))})"

    def __bool__(self):
        raise TypeError("an Expr has no truth value: use gt/lt/select")

    @property
    def is_const(self):
        return self.op == "const"


_TABLE: dict = {}


def _key_data(data):
    if isinstance(data, dict):
        return tuple(sorted(data.items()))
    return data


def _make(op, args, kind, data=None):
    key = (op, tuple(id(a) for a in args), kind, _key_data(data))
    node = _TABLE.get(key)
    if node is None:
        node = Expr(op, tuple(args), kind, data)
        _TABLE[key] = node
    return node


def wrap(x) -> Expr:
    """An Expr, a Python number (a float constant) or a 3-tuple of numbers
    or Exprs (a vector)."""
    if isinstance(x, Expr):
        return x
    if isinstance(x, bool):
        return const(1.0 if x else 0.0)
    if isinstance(x, (int, float)):
        return const(float(x))
    if isinstance(x, (tuple, list)) and len(x) == 3:
        return vec(*x)
    raise TypeError(f"cannot make an expression of {x!r}")


# --------------------------------------------------------------------------
# Leaves

def const(value: float) -> Expr:
    value = float(value)
    if value == 0.0:
        value = 0.0  # one zero (no -0.0)
    return _make("const", (), "f", value)


def vconst(x, y, z) -> Expr:
    return vec(const(x), const(y), const(z))


def packed(x, y, z) -> Expr:
    """A vector constant kept whole (a leaf, unlike :func:`vconst`, whose
    components are split out wherever one is used): arithmetic on it stays
    vector arithmetic, one native node per operation for three values.  For
    evaluating three series at once."""
    return _make("vlit", (), "v", tuple(0.0 if float(v) == 0.0 else float(v) for v in (x, y, z)))


def pack(x, y, z) -> Expr:
    """Three floats as one vector kept whole (unlike :func:`vec`, whose
    components are split out wherever an operation allows): arithmetic on
    it stays vector arithmetic, one native node per operation for three
    values.  For evaluating three series of computed coefficients at once;
    three constants are :func:`packed`."""
    x, y, z = wrap(x), wrap(y), wrap(z)
    if not (x.kind == y.kind == z.kind == "f"):
        raise TypeError("pack takes three floats")
    if all(a.op == "const" for a in (x, y, z)):
        return packed(x.data, y.data, z.data)
    return _make("pack", (x, y, z), "v")


def input_(name: str, kind: str = "f") -> Expr:
    """A named input: a model parameter, a socket of the group, or a value
    the backend provides (``geometry(...)``)."""
    if kind not in ("f", "v"):
        raise ValueError(kind)
    return _make("input", (), kind, (name, "param"))


def geometry(name: str, kind: str = "v") -> Expr:
    """A value the backend provides at the shading point: ``"N"`` (shading
    normal), ``"I"`` (unit vector toward the viewer), ``"P"`` (position),
    ``"uv_tangent"`` (the UV map's tangent, unit or zero)."""
    return _make("input", (), kind, (name, "geometry"))


# --------------------------------------------------------------------------
# Arithmetic with constant folding and the identities that hold for finite
# values (every value in a formula is finite: inputs are sanitised first).

def _c(x):
    return x.data if x.op == "const" else None


def _f32ok(v):
    return math.isfinite(v)


def _fold1(op, a):
    if op == "neg":
        return -a
    if op == "sqrt":
        return math.sqrt(a) if a > 0 else 0.0
    if op == "exp":
        return math.exp(a) if a < 700 else None
    if op == "log":
        return math.log(a) if a > 0 else 0.0
    if op == "sin":
        return math.sin(a)
    if op == "cos":
        return math.cos(a)
    if op == "tan":
        return math.tan(a)
    if op == "atan":
        return math.atan(a)
    if op == "abs":
        return abs(a)
    if op == "floor":
        return float(math.floor(a))
    if op == "finite":
        return 1.0 if math.isfinite(a) else 0.0
    return None


def _fold2(op, a, b):
    try:
        if op == "add":
            return a + b
        if op == "sub":
            return a - b
        if op == "mul":
            return a * b
        if op == "div":
            return a / b if b != 0 else 0.0
        if op == "pow":
            if b == 0:
                return 1.0
            if a == 0:
                return 0.0
            if a < 0 and b != math.floor(b):
                return 0.0
            return a ** b
        if op == "min":
            return min(a, b)
        if op == "max":
            return max(a, b)
        if op == "atan2":
            return math.atan2(a, b)
        if op == "gt":
            return 1.0 if a > b else 0.0
        if op == "lt":
            return 1.0 if a < b else 0.0
    except (OverflowError, ValueError, ZeroDivisionError):
        return None
    return None


def _unary(op, a):
    a = wrap(a)
    if a.kind != "f":
        raise TypeError(f"{op} takes a float, got {a.kind}")
    ca = _c(a)
    if ca is not None:
        v = _fold1(op, ca)
        if v is not None and _f32ok(v):
            return const(v)
    if op == "neg" and a.op == "neg":
        return a.args[0]
    return _make(op, (a,), "f")


def _binary(op, a, b):
    a, b = wrap(a), wrap(b)
    if a.kind == "v" or b.kind == "v":
        return _vbinary(op, a, b)
    if a.kind != "f" or b.kind != "f":
        raise TypeError(f"{op} takes floats or vectors")
    ca, cb = _c(a), _c(b)
    if ca is not None and cb is not None:
        v = _fold2(op, ca, cb)
        if v is not None and _f32ok(v):
            return const(v)
    if op == "add":
        if ca == 0.0:
            return b
        if cb == 0.0:
            return a
    elif op == "sub":
        if cb == 0.0:
            return a
        if ca == 0.0:
            return neg(b)
        if a is b:
            return const(0.0)
    elif op == "mul":
        if ca == 1.0:
            return b
        if cb == 1.0:
            return a
        if ca == 0.0 or cb == 0.0:
            return const(0.0)
        if ca == -1.0:
            return neg(b)
        if cb == -1.0:
            return neg(a)
        if a.op == "neg" and b.op == "neg":  # (-x)(-y) = x y
            return _binary("mul", a.args[0], b.args[0])
        if a.skey > b.skey:  # commutative: one order
            a, b = b, a
    elif op == "div":
        if cb == 1.0:
            return a
        if ca == 0.0:
            return const(0.0)
    elif op == "pow":
        if cb == 1.0:
            return a
        if cb == 0.0:
            return const(1.0)
    elif op in ("gt", "lt") and a.op == "neg" and cb == 0.0:
        # -x > 0 is x < 0 (and NaN is neither)
        return _make("lt" if op == "gt" else "gt", (a.args[0], b), "f")
    elif op in ("min", "max"):
        if a is b:
            return a
        if a.skey > b.skey:
            a, b = b, a
    return _make(op, (a, b), "f")


def add(a, b):
    return _binary("add", a, b)


def sub(a, b):
    return _binary("sub", a, b)


def mul(a, b):
    return _binary("mul", a, b)


def div(a, b):
    """a / b, and 0 where b == 0."""
    return _binary("div", a, b)


def neg(a):
    a = wrap(a)
    if a.kind == "v":
        return vscale(a, -1.0)
    return _unary("neg", a)


def sqrt(a):
    """Square root; 0 for a negative argument."""
    return _unary("sqrt", a)


def exp(a):
    return _unary("exp", a)


def log(a):
    """Natural logarithm; 0 for a non-positive argument."""
    return _unary("log", a)


def sin(a):
    return _unary("sin", a)


def cos(a):
    return _unary("cos", a)


def tan(a):
    return _unary("tan", a)


def atan(a):
    return _unary("atan", a)


def fabs(a):
    return _unary("abs", a)


def floor(a):
    return _unary("floor", a)


def finite(a):
    """1 if ``a`` is finite, 0 if it is NaN or infinite."""
    return _unary("finite", a)


def pow_(a, b):
    """a^b with Cycles' safe semantics (see the module docstring)."""
    return _binary("pow", a, b)


def fmin(a, b):
    return _binary("min", a, b)


def fmax(a, b):
    return _binary("max", a, b)


def atan2(y, x):
    return _binary("atan2", y, x)


def gt(a, b):
    """1.0 where a > b, else 0.0."""
    return _binary("gt", a, b)


def lt(a, b):
    """1.0 where a < b, else 0.0."""
    return _binary("lt", a, b)


def ge(a, b):
    """1.0 where a >= b, else 0.0."""
    return 1.0 - lt(a, b)


def select(c, a, b):
    """``a`` where ``c`` is 1, ``b`` where it is 0 (``c`` must be 0 or 1)."""
    c, a, b = wrap(c), wrap(a), wrap(b)
    if c.kind != "f":
        raise TypeError("select: the condition is a float 0 or 1")
    if a.kind != b.kind:
        raise TypeError("select: both branches must have the same kind")
    cc = _c(c)
    if cc is not None:
        return a if cc != 0.0 else b
    if a is b:
        return a
    if a.kind == "v" and a.op == "vec" and b.op == "vec":
        return vec(*(select(c, a[i], b[i]) for i in range(3)))
    return _make("select", (c, a, b), a.kind)


def clamp_input(x, lo, hi):
    """Clamp an input to [lo, hi]; NaN gives lo (the catalogue's rule)."""
    x = wrap(x)
    if x.kind == "v":
        return vec(*(clamp_input(x[i], lo, hi) for i in range(3)))
    return _make("clamp_input", (x,), "f", (float(lo), float(hi)))


def table(values, t):
    """Linear interpolation between ``values`` (at least two) at the evenly
    spaced knots 0, 1/(n-1), ..., 1, at ``t`` (clamped to [0, 1])."""
    values = tuple(float(x) for x in values)
    if len(values) < 2 or not all(math.isfinite(x) for x in values):
        raise ValueError("table: at least two finite values")
    if len(set(values)) == 1:
        return const(values[0])
    t = wrap(t)
    ct = _c(t)
    if ct is not None:
        u = min(max(ct, 0.0), 1.0) * (len(values) - 1)
        j = min(int(math.floor(u)), len(values) - 2)
        return const(values[j] + (u - j) * (values[j + 1] - values[j]))
    return _make("table", (t,), "f", values)


def clamp(x, lo, hi):
    """Clamp a finite value (no NaN rule)."""
    return fmin(fmax(x, lo), hi)


# --------------------------------------------------------------------------
# Vectors (3 components; colours too).  Arithmetic between vectors, a
# vector scaled by a float, dot, cross, length and normalize are primitives
# (one native node each); anything else works per component.

def vec(x, y, z) -> Expr:
    x, y, z = wrap(x), wrap(y), wrap(z)
    if not (x.kind == y.kind == z.kind == "f"):
        raise TypeError("vec takes three floats")
    # vec(v[0], v[1], v[2]) is v
    if x.op == "comp" and y.op == "comp" and z.op == "comp" and \
            x.args[0] is y.args[0] is z.args[0] and (x.data, y.data, z.data) == (0, 1, 2):
        return x.args[0]
    return _make("vec", (x, y, z), "v")


def comp(v, i: int) -> Expr:
    v = wrap(v)
    if v.kind != "v":
        raise TypeError("comp takes a vector")
    if v.op == "vec":
        return v.args[i]
    if v.op == "vlit":
        return const(v.data[i])
    if v.op in ("vadd", "vsub", "vmul") and any(a.op == "vec" for a in v.args):
        return _binary(v.op[1:], comp(v.args[0], i), comp(v.args[1], i))
    if v.op == "vscale" and (v.args[0].op == "vec" or v.args[1].is_const):
        return comp(v.args[0], i) * v.args[1]
    return _make("comp", (v,), "f", int(i))


def _is_vconst(v):
    return v.op == "vec" and all(a.op == "const" for a in v.args)


def _vbinary(op, a, b):
    if a.kind == "v" and b.kind == "v" and "vlit" in (a.op, b.op):
        if a.op == b.op == "vlit":
            folded = [_fold2(op, x, y) for x, y in zip(a.data, b.data)]
            if all(v is not None and _f32ok(v) for v in folded):
                return packed(*folded)
        if op in ("add", "sub") and b.op == "vlit" and b.data == (0.0, 0.0, 0.0):
            return a
        if op == "add" and a.op == "vlit" and a.data == (0.0, 0.0, 0.0):
            return b
        if op in ("add", "sub", "mul", "div"):
            return _make("v" + op, (a, b), "v")
    if a.kind == "v" and b.kind == "v":
        if op in ("add", "sub", "mul", "div") and not (_is_vconst(a) and _is_vconst(b)):
            if op == "mul" and _is_vconst(a) and len({x.data for x in a.args}) == 1:
                return vscale(b, a.args[0])
            if op == "mul" and _is_vconst(b) and len({x.data for x in b.args}) == 1:
                return vscale(a, b.args[0])
            if op in ("add", "sub") and _is_vconst(b) and all(x.data == 0.0 for x in b.args):
                return a
            if op == "add" and _is_vconst(a) and all(x.data == 0.0 for x in a.args):
                return b
            return _make("v" + op, (a, b), "v")
        return vec(*(_binary(op, a[i], b[i]) for i in range(3)))
    if op == "mul":
        return vscale(a, b) if a.kind == "v" else vscale(b, a)
    if op == "div" and a.kind == "v":
        return vscale(a, div(1.0, b))
    av = [a[i] for i in range(3)] if a.kind == "v" else [a] * 3
    bv = [b[i] for i in range(3)] if b.kind == "v" else [b] * 3
    return vec(*(_binary(op, x, y) for x, y in zip(av, bv)))


def vscale(v, f) -> Expr:
    """The vector ``v`` times the float ``f``."""
    v, f = wrap(v), wrap(f)
    cf = _c(f)
    if cf == 1.0:
        return v
    if v.op == "vlit" and cf is not None:
        folded = [x * cf for x in v.data]
        if all(_f32ok(x) for x in folded):
            return packed(*folded)
    if v.op == "vec" or cf == 0.0:
        return vec(*(comp(v, i) * f for i in range(3)))
    return _make("vscale", (v, f), "v")


def scaled(v, f) -> Expr:
    """The vector ``v`` times the float ``f`` as one vector operation, never
    split into components (:func:`vscale` splits a vector of three
    expressions): a closure's colour times its weight, one native node
    rather than three products and a Combine XYZ."""
    v, f = wrap(v), wrap(f)
    if v.kind != "v" or f.kind != "f":
        raise TypeError("scaled takes a vector and a float")
    if _c(f) is not None or v.op == "vlit":  # constants fold
        return vscale(v, f)
    return _make("vscale", (v, f), "v")


def dot(a, b):
    a, b = wrap(a), wrap(b)
    if a.op == "vec" and b.op == "vec":
        return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
    if a.skey > b.skey:
        a, b = b, a
    return _make("dot", (a, b), "f")


def cross(a, b):
    a, b = wrap(a), wrap(b)
    return _make("cross", (a, b), "v")


def reflect(i, n):
    """``i - 2 (n.i) n``, the mirror image of ``i`` in the plane of the unit
    vector ``n`` (the Vector Math node normalises ``n`` first)."""
    i, n = wrap(i), wrap(n)
    return _make("reflect", (i, n), "v")


def length(a):
    a = wrap(a)
    return _make("length", (a,), "f")


def normalize(a):
    """a / |a|, zero for a zero vector."""
    a = wrap(a)
    if a.op == "normalize":
        return a
    return _make("normalize", (a,), "v")


# --------------------------------------------------------------------------
# Structural choice and closures

class Enum:
    """A structural parameter seen by a formula: ``value`` is the variant's
    choice (native backend) or None (OSL: the shader gets the int code)."""

    def __init__(self, name: str, choices: tuple, value: str | None = None):
        if value is not None and value not in choices:
            raise ValueError(f"{name}={value!r}; allowed: {', '.join(choices)}")
        self.name = name
        self.choices = tuple(choices)
        self.value = value

    def __eq__(self, other):  # a formula may test a known choice directly
        raise TypeError("compare an Enum with is_(choice), or use choose()")

    __hash__ = object.__hash__

    def is_(self, *choices) -> Expr:
        """1 when the choice is one of ``choices`` (folds when known)."""
        if self.value is not None:
            return const(1.0 if self.value in choices else 0.0)
        return choose(self, {c: const(1.0 if c in choices else 0.0) for c in self.choices})


def choose(enum: Enum, branches: dict):
    """The branch of ``branches`` (choice -> Expr, or a function returning
    one, built only when needed) for the enum's choice.  Choices missing
    from ``branches`` take ``branches["*"]`` if present."""
    def get(choice):
        b = branches.get(choice, branches.get("*"))
        if b is None:
            raise KeyError(f"{enum.name}: no branch for {choice!r}")
        return wrap(b() if callable(b) else b)

    if enum.value is not None:
        return get(enum.value)
    built = {c: get(c) for c in enum.choices}
    first = next(iter(built.values()))
    if all(b is first for b in built.values()):
        return first
    kind = first.kind
    if any(b.kind != kind for b in built.values()):
        raise TypeError(f"choose({enum.name}): branches of different kinds")
    keys = tuple(enum.choices)
    return _make("choose", tuple(built[c] for c in keys), kind, (enum.name, keys))


def closure(name: str, weight, *args, **params) -> Expr:
    """A closure of the backend's library (:mod:`.closures`): ``name``, a
    colour ``weight`` and its arguments as expressions; ``params`` are
    constant strings/numbers (e.g. the distribution)."""
    weight = wrap(weight)
    if weight.kind == "f":
        weight = vec(weight, weight, weight)
    return _make("closure", (weight,) + tuple(wrap(a) for a in args), "c",
                 (name, tuple(sorted(params.items()))))


def engine_switch(cycles, eevee, eevee_in_cycles=0.0) -> Expr:
    """The closure ``cycles`` in Cycles and ``eevee`` in EEVEE, for a
    closure EEVEE renders as another (its Toon BSDF is a diffuse one); where
    the float ``eevee_in_cycles`` (0 or 1) is 1, ``eevee`` in Cycles too.
    Only the native nodes offer it (a Mix Shader whose factor is EEVEE's
    Shader to RGB of an emission, 1 in EEVEE, or ``eevee_in_cycles``; in
    Cycles, which has no Shader to RGB node, that input's own value, 0)."""
    cycles, eevee, both = wrap(cycles), wrap(eevee), wrap(eevee_in_cycles)
    if cycles.kind != "c" or eevee.kind != "c" or both.kind != "f":
        raise TypeError("engine_switch takes two closures and a float")
    if _c(both) == 1.0:
        return eevee
    return _make("engine_switch", (cycles, eevee, both), "c")


def closure_sum(*terms) -> Expr:
    terms = [t for t in terms if t is not None]
    if not terms:
        return _make("closure_sum", (), "c")
    if len(terms) == 1:
        return terms[0]
    return _make("closure_sum", tuple(terms), "c")


# --------------------------------------------------------------------------
# Walking a graph

def topological(roots) -> list:
    """Every node reachable from ``roots``, dependencies first."""
    order, seen = [], set()
    stack = [(r, False) for r in reversed(list(roots))]
    while stack:
        node, done = stack.pop()
        if done:
            order.append(node)
            continue
        if id(node) in seen:
            continue
        seen.add(id(node))
        stack.append((node, True))
        for a in reversed(node.args):
            if id(a) not in seen:
                stack.append((a, False))
    return order


def inputs_of(roots) -> list:
    """The input leaves reachable from ``roots``: ``(name, source, kind)``."""
    return [(n.data[0], n.data[1], n.kind) for n in topological(roots) if n.op == "input"]


def count(roots) -> int:
    """Nodes reachable from ``roots`` that are not leaves."""
    return sum(1 for n in topological(roots) if n.op not in LEAVES)


def occluded(position, direction, max_distance, enabled) -> Expr:
    """1 if a shadow ray from ``position`` along ``direction`` hits
    something closer than ``max_distance``, else 0; 0 when ``enabled`` is 0.
    A backend primitive: OSL's trace(), the native Raycast node (Blender 5.x;
    none in 4.5, where nothing is occluded)."""
    return _make("occluded", tuple(wrap(a) for a in (position, direction, max_distance, enabled)),
                 "f")
