"""Several states at once: CasADi's generated straight-line C rewritten over GCC vector types.

CasADi writes an SX function as straight-line code on scalar locals ``aNNN`` (declared
``casadi_real``): loads ``aNNN=arg[k]? arg[k][i] : 0;``, assignments ``aNNN=expr;`` of
arithmetic, ``sqrt``/``sin``/... and its helpers (``casadi_sq``, ``casadi_fabs``,
``casadi_fmax``...), comparisons ``aNNN=(x<y);`` and selections ``aNNN=(c?x:y);``, and
stores ``if (res[k]!=0) res[k][i]=aNNN;``. :func:`vector_source` rewrites that body over
``sp_vec``, a vector of :data:`WIDTH` doubles (GCC/Clang ``vector_size``: SSE2 on any
x86-64, no ``-march``), one state per lane: lane ``l`` reads ``argv[l]`` and writes
``resv[l]``. The operations are the scalar code's, in the same order, lane by lane (IEEE
arithmetic, no contraction without ``-march``); the mathematical functions, comparisons
and selections are evaluated lane by lane with the scalar ones. Each lane's result is the
scalar function's but where ``-freciprocal-math`` (:data:`.compiled.CFLAGS`) turns
divisions by one divisor into products by its reciprocal in one and not the other (the
compiler's threshold differs for vectors): up to about 1e-15 relative, measured
(tests/test_compiled_calls.py checks 1e-13).

Anything else in a body (a branch, a loop, a call of another function, a function not
in :data:`_LANEWISE`) leaves that function out: the batch loop keeps its scalar path.
Two doubles per vector: four (two SSE2 registers per operation) measured slower.
"""

from __future__ import annotations

import re

#: States per vector (two doubles: one SSE2 register).
WIDTH = 2

#: Functions of the generated code, called lane by lane (the scalar function, one or two
#: arguments).
_LANEWISE = {
    "sqrt": 1,
    "sin": 1,
    "cos": 1,
    "tan": 1,
    "asin": 1,
    "acos": 1,
    "atan": 1,
    "exp": 1,
    "log": 1,
    "fabs": 1,
    "floor": 1,
    "ceil": 1,
    "tanh": 1,
    "sinh": 1,
    "cosh": 1,
    "casadi_fabs": 1,
    "casadi_sign": 1,
    "atan2": 2,
    "pow": 2,
    "fmin": 2,
    "fmax": 2,
    "casadi_fmin": 2,
    "casadi_fmax": 2,
    "copysign": 2,
}

_DECL = re.compile(r"^\s*casadi_real (a\d+(?:, a\d+)*);$")
_LOAD = re.compile(r"^\s*(a\d+)=arg\[(\d+)\]\? arg\[\2\]\[(\d+)\] : 0;$")
_STORE = re.compile(r"^\s*if \(res\[(\d+)\]!=0\) res\[\1\]\[(\d+)\]=(a\d+);$")
_ASSIGN = re.compile(r"^\s*(a\d+)=([^;?<>=!&|{}]*);$")
_OPERAND = r"(a\d+|[0-9][0-9.eE+-]*)"
#: ``aNNN=(x<y);`` (a comparison: 1 or 0) and ``aNNN=(c?x:y);`` (if_else), lane by lane.
_COMPARE = re.compile(rf"^\s*(a\d+)=\({_OPERAND}(<|<=|>|>=|==|!=){_OPERAND}\);$")
_SELECT = re.compile(rf"^\s*(a\d+)=\({_OPERAND}\?{_OPERAND}:{_OPERAND}\);$")
_CALL = re.compile(r"([A-Za-z_]\w*)\(")
_VAR = re.compile(r"\ba\d+\b")


def function_body(source: str, name: str) -> list[str] | None:
    """The lines of the body of ``static int name(...) {`` in CasADi's ``source`` up to
    its ``return 0;`` (None if not found)."""
    lines = source.splitlines()
    head = f"static int {name}(const casadi_real** arg, casadi_real** res,"
    for k, line in enumerate(lines):
        if line.startswith(head) and line.rstrip().endswith("{"):
            body: list[str] = []
            for line2 in lines[k + 1 :]:
                if line2.strip() == "return 0;":
                    return body
                body.append(line2)
            return None
    return None


def _internal_name(source: str, name: str) -> str | None:
    """The ``casadi_fN`` the exported ``name`` of CasADi's ``source`` calls."""
    m = re.search(
        r"int " + re.escape(name) + r"\(const casadi_real\*\* arg[^{]*\{\s*return (casadi_f\d+)\(",
        source,
    )
    return m.group(1) if m else None


def vector_source(source: str, names: dict[str, str]) -> tuple[str, set[str]]:
    """The C, to follow CasADi's ``source``, of ``static void vname(const double* const*
    argv[WIDTH], double* const* resv[WIDTH])`` for each exported function ``name`` of
    ``names`` (``{name: vname}``) whose body is plain straight-line code, with the vector
    type and the lane-by-lane functions they call; and the set of the ``vname`` written
    (the others: keep the scalar loop)."""
    used: set[str] = set()
    bodies: list[str] = []
    written: set[str] = set()
    for name, vname in names.items():
        internal = _internal_name(source, name)
        code = None if internal is None else _vector_function(source, internal, vname, used)
        if code is not None:
            bodies.append(code)
            written.add(vname)
    if not written:
        return "", written
    lanes = range(WIDTH)
    parts = [
        "/* ---- stewart-pin: several states at once (see codegen/_simd.py) ---- */",
        f"#define SP_WIDTH {WIDTH}",
        f"typedef double sp_vec __attribute__((vector_size({8 * WIDTH})));",
        "static const sp_vec sp_vec_zero = {0};",
    ]
    for fn in sorted(used):
        n = _LANEWISE.get(fn, 1)
        if fn == "casadi_sq":
            parts.append("static inline sp_vec sp_v_casadi_sq(sp_vec x) { return x * x; }")
        elif n == 1:
            items = ", ".join(f"{fn}(x[{lane}])" for lane in lanes)
            parts.append(
                f"static inline sp_vec sp_v_{fn}(sp_vec x) {{ return (sp_vec){{{items}}}; }}"
            )
        else:
            items = ", ".join(f"{fn}(x[{lane}], y[{lane}])" for lane in lanes)
            parts.append(
                f"static inline sp_vec sp_v_{fn}(sp_vec x, sp_vec y) "
                f"{{ return (sp_vec){{{items}}}; }}"
            )
    return "\n".join(parts) + "\n" + "\n".join(bodies), written


def _vector_function(source: str, name: str, vname: str, used: set[str]) -> str | None:
    body = function_body(source, name)
    if body is None:
        return None
    out: list[str] = []
    lanes = range(WIDTH)
    calls: set[str] = set()
    for line in body:
        if not line.strip():
            continue
        m = _DECL.match(line)
        if m:
            out.append(f"  sp_vec {m.group(1)};")
            continue
        m = _LOAD.match(line)
        if m:
            v, k, i = m.groups()
            items = ", ".join(f"argv[{lane}][{k}][{i}]" for lane in lanes)
            out.append(f"  {v}=(sp_vec){{{items}}};")
            continue
        m = _STORE.match(line)
        if m:
            k, i, v = m.groups()
            out.append("  " + " ".join(f"resv[{lane}][{k}][{i}]={v}[{lane}];" for lane in lanes))
            continue
        m = _COMPARE.match(line) or _SELECT.match(line)
        if m:
            v, *terms = m.groups()
            ops = terms[1::2] if m.re is _COMPARE else ["?", ":"]
            xs = terms[0::2] if m.re is _COMPARE else terms
            per_lane = []
            for lane in lanes:
                at = [f"{x}[{lane}]" if _VAR.fullmatch(x) else x for x in xs]
                per_lane.append(at[0] + "".join(o + a for o, a in zip(ops, at[1:], strict=True)))
            out.append(f"  {v}=(sp_vec){{{', '.join(f'({it})' for it in per_lane)}}};")
            continue
        m = _ASSIGN.match(line)
        if not m:
            return None
        v, expr = m.groups()
        found = set(_CALL.findall(expr))
        if not found <= set(_LANEWISE) | {"casadi_sq"}:
            return None
        calls |= found
        if not _VAR.search(expr):  # a constant: broadcast
            out.append(f"  {v}=sp_vec_zero+({expr});")
            continue
        out.append(f"  {v}={_CALL.sub(lambda c: f'sp_v_{c.group(1)}(', expr)};")
    used |= calls
    return (
        f"static void {vname}(const double* const* argv[{WIDTH}], double* const* "
        f"resv[{WIDTH}]) {{\n" + "\n".join(out) + "\n}\n"
    )
