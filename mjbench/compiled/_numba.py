"""Compiled implementations of the bridges (imported with numba by :mod:`mjbench.compiled.jit`)."""
from llvmlite import ir
from numba import types
from numba.extending import intrinsic


@intrinsic
def _call_pp(typingctx, fn, a, b):
    """``fn(a, b)`` for a C function ``void fn(void*, void*)`` given by its address (MuJoCo's
    ``mj_step(const mjModel*, mjData*)``): the addresses are run-time integers, so a function using
    it is cached on disk like any other (a ctypes function object as an argument is not)."""
    sig = types.void(types.intp, types.intp, types.intp)

    def codegen(context, builder, signature, args):
        vp = ir.IntType(8).as_pointer()
        f = builder.inttoptr(args[0], ir.FunctionType(ir.VoidType(), [vp, vp]).as_pointer())
        builder.call(f, [builder.inttoptr(args[1], vp), builder.inttoptr(args[2], vp)])
        return context.get_dummy_value()
    return sig, codegen


def call_c_pp(fn, a, b):
    """The compiled :func:`mjbench.backends.multibody.call_c_pp`: a direct call through the address."""
    def impl(fn, a, b):
        _call_pp(fn, a, b)
    return impl


@intrinsic
def _bicubic(typingctx, rows, r, s, t, out, o, nvec):
    """:func:`mjbench.mechanisms.linkage.multi.bicubic_lanes` in LLVM vectors: for each of the
    ``nvec`` 4-lane registers, Horner in t for each power of s, then in s — ``fmul`` and ``fadd``
    without fast-math flags, in the Python law's order (the same bits per lane).  ``rows`` a
    C-contiguous 2-D and ``out`` a contiguous 1-D float64 array; the caller keeps r, o and nvec within
    them (the table's own row, a state sized for 4·nvec channels)."""
    arr2, arr1 = types.Array(types.float64, 2, "C"), types.Array(types.float64, 1, "C")
    if rows != arr2 or out != arr1:
        return None
    ints = (r, o, nvec)
    if not all(isinstance(x, types.Integer) for x in ints) or not all(isinstance(x, types.Float) for x in (s, t)):
        return None
    sig = types.void(rows, r, s, t, out, o, nvec)

    def codegen(context, builder, signature, args):
        from numba.core import cgutils

        R = context.make_array(signature.args[0])(context, builder, args[0])
        O = context.make_array(signature.args[4])(context, builder, args[4])
        r_, o_, nv = (context.cast(builder, args[k], signature.args[k], types.intp) for k in (1, 5, 6))
        s_, t_ = (context.cast(builder, args[k], signature.args[k], types.float64) for k in (2, 3))
        i64, i32 = ir.IntType(64), ir.IntType(32)
        vec = ir.VectorType(ir.DoubleType(), 4)
        undef = ir.Constant(vec, ir.Undefined)

        def splat(x):
            return builder.shuffle_vector(builder.insert_element(undef, x, ir.Constant(i32, 0)), undef,
                                          ir.Constant(ir.VectorType(i32, 4), [0, 0, 0, 0]))

        sv, tv = splat(s_), splat(t_)
        row = builder.add(builder.ptrtoint(R.data, i64), builder.mul(r_, builder.extract_value(R.strides, 0)))
        dst = builder.add(builder.ptrtoint(O.data, i64), builder.mul(o_, ir.Constant(i64, 8)))
        step = builder.mul(nv, ir.Constant(i64, 32))  # one coefficient's L lanes [bytes]
        with cgutils.for_range(builder, nv) as loop:
            off = builder.mul(loop.index, ir.Constant(i64, 32))
            base = builder.add(row, off)

            def coef(m):
                a = builder.add(base, builder.mul(step, ir.Constant(i64, m)))
                return builder.load(builder.inttoptr(a, vec.as_pointer()), align=8)

            a = []
            for k in range(4):
                x = builder.fadd(builder.fmul(coef(4 * k), tv), coef(4 * k + 1))
                x = builder.fadd(builder.fmul(x, tv), coef(4 * k + 2))
                a.append(builder.fadd(builder.fmul(x, tv), coef(4 * k + 3)))
            w = builder.fadd(builder.fmul(a[0], sv), a[1])
            w = builder.fadd(builder.fmul(w, sv), a[2])
            w = builder.fadd(builder.fmul(w, sv), a[3])
            builder.store(w, builder.inttoptr(builder.add(dst, off), vec.as_pointer()), align=8)
        return context.get_dummy_value()
    return sig, codegen


def bicubic_lanes(R, r, s, t, out, o, nvec):
    """The compiled :func:`mjbench.mechanisms.linkage.multi.bicubic_lanes` (:func:`_bicubic`)."""
    def impl(R, r, s, t, out, o, nvec):
        _bicubic(R, r, s, t, out, o, nvec)
    return impl
