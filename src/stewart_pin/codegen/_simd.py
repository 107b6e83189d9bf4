"""Several states at once: CasADi's generated straight-line C rewritten over GCC vector types.

CasADi writes an SX function as straight-line code on scalar locals ``aNNN`` (declared
``casadi_real``): loads ``aNNN=arg[k]? arg[k][i] : 0;``, assignments ``aNNN=expr;`` of
arithmetic, ``sqrt``/``sin``/... and its helpers (``casadi_sq``, ``casadi_fabs``,
``casadi_fmax``...), comparisons ``aNNN=(x<y);``, logic ``aNNN=(x&&y);``, ``(x||y)``,
``(!x)`` and selections ``aNNN=(c?x:y);``, and
stores ``if (res[k]!=0) res[k][i]=aNNN;``. :func:`vector_source` rewrites that body over
``sp_vec``, a vector of ``SP_WIDTH`` doubles (GCC/Clang ``vector_size``), one state per
lane: the inputs come as a structure of arrays (``argv[k][i]``: element ``i`` of argument
``k``, one lane per state, which the caller gathers once and its guards read again), an
argument shared by every lane (the base parameters) as one array ``shared[k]``, read once
and broadcast; lane ``l`` writes ``resv[l]``, but for the by-products output (``res[1]``),
written whole vectors at a time to a structure of arrays ``soa[i]`` (lane ``l`` of
``soa[i]`` being the state's ``aux[i]``). The text does not
depend on the width; :data:`PREAMBLE` chooses it when the library is compiled:

- x86-64 (and x86) with GCC or Clang: four doubles (AVX2), the vector functions compiled
  for AVX2 alone (``__attribute__((target("avx2")))``: no FMA, so the same roundings as
  the scalar code) and used only when the processor has AVX2 (``SP_VEC_READY()``:
  ``__builtin_cpu_supports``, asked when the library is loaded); on an x86-64 without
  AVX2 the batch loops take the scalar path (one copy of the code is compiled, not two:
  the compile time). The library itself is built without ``-march``: it loads and runs on
  any x86-64;
- any other processor: two doubles (NEON on AArch64), always used.

The operations are the scalar code's, in the same order, lane by lane (IEEE arithmetic, no
contraction); ``sqrt`` is the processor's vector square root (correctly rounded, as the
scalar one), ``fabs``, ``fmax``/``fmin`` (C99: a NaN operand yields the other),
``casadi_sign``, comparisons and selections are written with lane masks (the same values
as the scalar functions, signed zeros and NaN included up to the sign of a zero from
``fmax(-0, +0)``); the other mathematical functions are called lane by lane. Each lane's
result is the scalar function's but where ``-freciprocal-math`` (:data:`.compiled.CFLAGS`)
turns divisions by one divisor into products by its reciprocal in one and not the other:
up to about 1e-15 relative, measured (tests/test_compiled_calls.py checks 1e-13).

A call of another generated function (CasADi's ``arg[k]=w+N; res[k]=w+N; w[i] = aNNN;
if (casadi_fN(arg+A, res+R, iw, w+W, 0)) return 1; aNNN = w[i];``: the chain legs' Newton
steps, issue 20) becomes a call of that function's vector copy ``sp_vf_casadi_fN`` (written
once, not inlined: the compile time) on a local vector workspace, if its body is
straight-line code in turn. Anything else in a body (a branch, a loop, a function not in
:data:`_LANEWISE`) leaves that function out: the batch loop keeps its scalar path.
Measured (issue 24): four doubles over SSE2 (two registers per operation) were slower than
two; AVX2 four-wide is 1.4-1.5x faster than SSE2 two-wide on the generated code, AVX-512
eight-wide only 1.1x more (and more states in the scalar tail), so it is not used.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

#: The C before the vector functions: the width, the vector types, ``SP_VTARGET`` (the
#: target of every vector function), ``SP_VEC_READY()`` (whether the processor runs them),
#: ``SP_STRIDED(p, d, k)`` (element ``k`` of ``SP_WIDTH`` arrays ``d`` apart from ``p``),
#: ``sp_bcast`` and the exact lane-mask helpers.
PREAMBLE = r"""
/* ---- stewart-pin: several states at once (see codegen/_simd.py) ---- */
#if (defined(__x86_64__) || defined(__i386__)) && (defined(__GNUC__) || defined(__clang__))
#include <immintrin.h>
#define SP_WIDTH 4
#define SP_VTARGET __attribute__((target("avx2")))
typedef double sp_vec __attribute__((vector_size(32)));
static int sp_vec_ready = 0;  /* the processor has AVX2: set when the library is loaded */
__attribute__((constructor)) static void sp_vec_init(void) {
  __builtin_cpu_init();
  sp_vec_ready = __builtin_cpu_supports("avx2") ? 1 : 0;
}
#define SP_VEC_READY() sp_vec_ready
#define SP_STRIDED(p, d, k) \
  ((sp_vec){(p)[k], (p)[(d) + (k)], (p)[2 * (d) + (k)], (p)[3 * (d) + (k)]})
SP_VTARGET static inline sp_vec sp_bcast(double x) { return (sp_vec){x, x, x, x}; }
SP_VTARGET static inline sp_vec sp_v_sqrt(sp_vec x) { return _mm256_sqrt_pd(x); }
#else
#define SP_WIDTH 2
#define SP_VTARGET
typedef double sp_vec __attribute__((vector_size(16)));
#define SP_VEC_READY() 1
#define SP_STRIDED(p, d, k) ((sp_vec){(p)[k], (p)[(d) + (k)]})
static inline sp_vec sp_bcast(double x) { return (sp_vec){x, x}; }
static inline sp_vec sp_v_sqrt(sp_vec x) {
  sp_vec r; int l;
  for (l = 0; l < SP_WIDTH; ++l) r[l] = sqrt(x[l]);
  return r;
}
#endif
/* the screens' short loops unrolled (their arrays then stay in registers) */
#if defined(__GNUC__) && !defined(__clang__)
#define SP_UNROLL _Pragma("GCC unroll 36")
#else
#define SP_UNROLL
#endif
/* the lane masks of comparisons (all ones where true) */
typedef __typeof__((sp_vec){0} < (sp_vec){0}) sp_ivec;
#define SP_ALL (sp_bcast(0.0) == sp_bcast(0.0))
/* m ? x : y lane by lane (m: all ones or zeros per lane) */
SP_VTARGET static inline sp_vec sp_sel(sp_ivec m, sp_vec x, sp_vec y) {
  return (sp_vec)((m & (sp_ivec)x) | (~m & (sp_ivec)y));
}
/* 1.0 where m, else 0.0 (a C comparison's value) */
SP_VTARGET static inline sp_vec sp_bool(sp_ivec m) { return (sp_vec)(m & (sp_ivec)sp_bcast(1.0)); }
SP_VTARGET static inline sp_vec sp_v_fabs(sp_vec x) {
  return (sp_vec)(~(sp_ivec)sp_bcast(-0.0) & (sp_ivec)x);
}
SP_VTARGET static inline sp_vec sp_v_fmax(sp_vec x, sp_vec y) {
  return sp_sel((x > y) | (y != y), x, y);
}
SP_VTARGET static inline sp_vec sp_v_fmin(sp_vec x, sp_vec y) {
  return sp_sel((x < y) | (y != y), x, y);
}
SP_VTARGET static inline sp_vec sp_v_casadi_sq(sp_vec x) { return x * x; }
SP_VTARGET static inline sp_vec sp_v_casadi_fabs(sp_vec x) { return sp_v_fabs(x); }
SP_VTARGET static inline sp_vec sp_v_casadi_fmax(sp_vec x, sp_vec y) { return sp_v_fmax(x, y); }
SP_VTARGET static inline sp_vec sp_v_casadi_fmin(sp_vec x, sp_vec y) { return sp_v_fmin(x, y); }
SP_VTARGET static inline sp_vec sp_v_casadi_sign(sp_vec x) {
  return sp_sel(x < 0.0, sp_bcast(-1.0), sp_sel(x > 0.0, sp_bcast(1.0), x));
}
"""

#: Helpers of :data:`PREAMBLE` (exact lane-mask or vector forms of the scalar functions).
_VECTOR_FORMS = {
    "sqrt",
    "fabs",
    "fmax",
    "fmin",
    "casadi_sq",
    "casadi_fabs",
    "casadi_fmax",
    "casadi_fmin",
    "casadi_sign",
}

#: Functions of the generated code, called lane by lane (the scalar function, one or two
#: arguments), unless :data:`_VECTOR_FORMS` has them.
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
    "fmod": 2,
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
#: ``aNNN=(x&&y);``, ``aNNN=(x||y);`` and ``aNNN=(!x);`` (1 or 0), lane by lane.
_LOGIC = re.compile(rf"^\s*(a\d+)=\({_OPERAND}(&&|\|\|){_OPERAND}\);$")
_NOT = re.compile(rf"^\s*(a\d+)=\(!{_OPERAND}\);$")
#: A call of another generated function: its pointers into ``w``, the values copied in and
#: out, and the call itself.
_POINTER = re.compile(r"^\s*(arg|res)\[(\d+)\]=w\+(\d+);$")
_COPY_IN = re.compile(rf"^\s*w\[(\d+)\] = {_OPERAND};$")
_COPY_OUT = re.compile(r"^\s*(a\d+) = w\[(\d+)\];$")
_SUBCALL = re.compile(
    r"^\s*if \((casadi_f\d+)\(arg\+(\d+), res\+(\d+), iw, w\+\d+, 0\)\) return 1;$"
)
_VAR = re.compile(r"\ba\d+\b")
#: The output written as a structure of arrays (``soa``): the by-products.
SOA_OUTPUT = 1


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


def internal_name(source: str, name: str) -> str | None:
    """The ``casadi_fN`` the exported ``name`` of CasADi's ``source`` calls."""
    m = re.search(
        r"int " + re.escape(name) + r"\(const casadi_real\*\* arg[^{]*\{\s*return (casadi_f\d+)\(",
        source,
    )
    return m.group(1) if m else None


def vector_source(
    source: str, names: dict[str, str], shared: frozenset[int] = frozenset()
) -> tuple[str, set[str]]:
    """The C, to follow CasADi's ``source``, of ``static void vname(const sp_vec* const*
    argv, const double* const* shared, double* const* resv[SP_WIDTH], sp_vec* soa)`` for
    each exported function ``name`` of ``names`` (``{name: vname}``) whose body is plain
    straight-line code (the arguments numbered in ``shared`` read from ``shared[k]`` and
    broadcast, the others from ``argv[k]``; output :data:`SOA_OUTPUT` goes to ``soa``, the
    others lane by lane to ``resv``), after
    :data:`PREAMBLE` and the lane-by-lane functions they call; and the set of the
    ``vname`` written (the others: keep the scalar loop)."""
    used: set[str] = set()
    bodies: list[str] = []
    written: set[str] = set()
    callees: dict[str, _Callee | None] = {}
    for name, vname in names.items():
        internal = internal_name(source, name)
        code = (
            None
            if internal is None
            else _vector_function(source, internal, vname, used, shared, callees)
        )
        if code is not None:
            bodies.append(code)
            written.add(vname)
    if not written:
        return "", written
    helpers = lane_helpers(used)
    parts = [PREAMBLE, helpers] if helpers else [PREAMBLE]
    parts += [c.code for c in callees.values() if c is not None]
    return "\n".join(parts) + "\n" + "\n".join(bodies), written


def lane_helpers(used: set[str]) -> str:
    """The C of the lane-by-lane functions ``sp_v_<fn>`` of the functions ``used`` by
    vector bodies (those :data:`PREAMBLE` does not write in vector form)."""
    parts = []
    for fn in sorted(used - _VECTOR_FORMS):
        if _LANEWISE.get(fn, 1) == 1:
            parts.append(
                f"SP_VTARGET static inline sp_vec sp_v_{fn}(sp_vec x) {{\n"
                f"  sp_vec r; int l;\n  for (l = 0; l < SP_WIDTH; ++l) r[l] = {fn}(x[l]);\n"
                "  return r;\n}"
            )
        else:
            parts.append(
                f"SP_VTARGET static inline sp_vec sp_v_{fn}(sp_vec x, sp_vec y) {{\n"
                f"  sp_vec r; int l;\n  for (l = 0; l < SP_WIDTH; ++l) r[l] = {fn}(x[l], y[l]);\n"
                "  return r;\n}"
            )
    return "\n".join(parts)


def _operand(x: str) -> str:
    return x if _VAR.fullmatch(x) else f"sp_bcast({x})"


@dataclass
class _Callee:
    """The vector copy of a called function: its C, its numbers of inputs and outputs and
    the elements it reads of each input."""

    code: str
    n_in: int
    n_out: int
    sizes: dict[int, int]


def _vector_function(
    source: str,
    name: str,
    vname: str,
    used: set[str],
    shared: frozenset[int],
    callees: dict[str, _Callee | None],
) -> str | None:
    out = vector_lines(source, name, used, shared, callees, called=False)
    if out is None:
        return None
    return (
        f"SP_VTARGET static void {vname}(const sp_vec* const* argv, const double* const* "
        f"shared, double* const* resv[SP_WIDTH], sp_vec* soa) {{\n  int l;\n"
        + "\n".join(out)
        + "\n  (void)l; (void)argv; (void)shared;\n}\n"
    )


def _callee(
    source: str, name: str, used: set[str], callees: dict[str, _Callee | None]
) -> _Callee | None:
    """The vector copy ``sp_vf_<name>(const sp_vec* const* argv, sp_vec* const* resv)`` of
    the called function ``name`` (None if it is not straight-line code), written once."""
    if name not in callees:
        callees[name] = None  # a call of itself: not written
        body = function_body(source, name)
        inner: set[str] = set()
        out = (
            None if body is None else vector_lines(source, name, inner, frozenset(), callees, True)
        )
        if out is not None and body is not None:
            used |= inner
            loads = [_LOAD.match(x) for x in body]
            sizes: dict[int, int] = {}
            for m in loads:
                if m:
                    k, i = int(m.group(2)), int(m.group(3))
                    sizes[k] = max(sizes.get(k, 0), i + 1)
            n_out = 1 + max((int(m.group(1)) for x in body if (m := _STORE.match(x))), default=-1)
            code = (
                f"SP_VTARGET __attribute__((noinline)) static void sp_vf_{name}("
                "const sp_vec* const* argv, sp_vec* const* resv) {\n"
                + "\n".join(out)
                + "\n  (void)argv; (void)resv;\n}\n"
            )
            del callees[name]  # after the functions it calls
            callees[name] = _Callee(code, 1 + max(sizes, default=-1), n_out, sizes)
    return callees[name]


def vector_lines(
    source: str,
    name: str,
    used: set[str],
    shared: frozenset[int],
    callees: dict[str, _Callee | None],
    called: bool,
) -> list[str] | None:
    """The vector body of function ``name`` (None if it is not straight-line code); a
    ``called`` function reads ``argv[k][i]`` and writes ``resv[k][i]``."""
    body = function_body(source, name)
    if body is None:
        return None
    out: list[str] = []
    calls: set[str] = set()
    pointers: dict[tuple[str, int], int] = {}
    nw = 0
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
            if int(k) in shared:
                out.append(f"  {v}=sp_bcast(shared[{k}][{i}]);")
            else:
                out.append(f"  {v}=argv[{k}][{i}];")
            continue
        m = _STORE.match(line)
        if m:
            k, i, v = m.groups()
            if called:
                out.append(f"  resv[{k}][{i}]={v};")
            elif int(k) == SOA_OUTPUT:
                out.append(f"  soa[{i}]={v};")
            else:
                out.append(f"  for (l = 0; l < SP_WIDTH; ++l) resv[l][{k}][{i}]={v}[l];")
            continue
        m = _POINTER.match(line)
        if m:
            pointers[(m.group(1), int(m.group(2)))] = int(m.group(3))
            continue
        m = _COPY_IN.match(line)
        if m:
            i, x = m.groups()
            nw = max(nw, int(i) + 1)
            out.append(f"  vw[{i}]={_operand(x)};")
            continue
        m = _COPY_OUT.match(line)
        if m:
            v, i = m.groups()
            nw = max(nw, int(i) + 1)
            out.append(f"  {v}=vw[{i}];")
            continue
        m = _SUBCALL.match(line)
        if m:
            fn, a, r = m.group(1), int(m.group(2)), int(m.group(3))
            c = _callee(source, fn, used, callees)
            ins = [pointers.get(("arg", a + j)) for j in range(c.n_in)] if c else [None]
            outs = [pointers.get(("res", r + j)) for j in range(c.n_out)] if c else [None]
            if c is None or None in ins or None in outs:
                return None
            nw = max([nw] + [o + c.sizes.get(j, 0) for j, o in enumerate(ins) if o is not None])
            out.append(
                f"  {{ const sp_vec* ca[] = {{{', '.join(f'vw+{o}' for o in ins)}}}; "
                f"sp_vec* cr[] = {{{', '.join(f'vw+{o}' for o in outs)}}}; "
                f"sp_vf_{fn}(ca, cr); }}"
            )
            continue
        m = _COMPARE.match(line)
        if m:
            v, x, op, y = m.groups()
            out.append(f"  {v}=sp_bool({_operand(x)}{op}{_operand(y)});")
            continue
        m = _LOGIC.match(line)
        if m:
            v, x, op, y = m.groups()
            out.append(f"  {v}=sp_bool(({_operand(x)}!=0.0){op[0]}({_operand(y)}!=0.0));")
            continue
        m = _NOT.match(line)
        if m:
            v, x = m.groups()
            out.append(f"  {v}=sp_bool({_operand(x)}==0.0);")
            continue
        m = _SELECT.match(line)
        if m:
            v, c_, x, y = m.groups()
            out.append(f"  {v}=sp_sel({_operand(c_)}!=0.0, {_operand(x)}, {_operand(y)});")
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
            out.append(f"  {v}=sp_bcast({expr});")
            continue
        out.append(f"  {v}={_CALL.sub(lambda c: f'sp_v_{c.group(1)}(', expr)};")
    used |= calls
    if nw:
        out.insert(0, f"  sp_vec vw[{nw}];")
    return out
