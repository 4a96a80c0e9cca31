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
