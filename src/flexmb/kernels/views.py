"""Views of a contiguous buffer as 2-d and 3-d arrays, made in compiled code without numba's reshape.

numba's ``a[o : o + r * c].reshape((r, c))`` calls a runtime helper (with
its checks) for every view; a right-hand side that carves its work arrays,
or the model's packed buffers (:mod:`flexmb.kernels.packing`), out of a
few buffers makes dozens of views per call. :func:`view2` and
:func:`view3` build the same C-ordered view directly: the buffer's data
pointer moved by ``o`` items, the shape given, the strides of C order, the
buffer's reference (its memory stays alive while the view does). No check
is made that the view lies within the buffer: the callers size their
buffers (:func:`flexmb.kernels.articulated.rhs_work_size`,
:func:`flexmb.kernels.packing.pack`).
"""

from __future__ import annotations

from numba.core import cgutils, types
from numba.core.errors import TypingError
from numba.core.imputils import impl_ret_borrowed
from numba.extending import intrinsic

__all__ = ["view2", "view3"]


def _view(typingctx, buffer, offset, dims):
    """The typing and code of a C-ordered view of ``buffer`` from item ``offset``, of the shape ``dims``."""
    if not isinstance(buffer, types.Array) or buffer.ndim != 1 or buffer.layout != "C":
        raise TypingError(f"a view needs a contiguous 1-d array, got {buffer}")
    out_type = types.Array(buffer.dtype, len(dims), "C")

    def codegen(context, builder, sig, args):
        src = context.make_array(sig.args[0])(context, builder, args[0])
        out = context.make_array(out_type)(context, builder)
        itemsize = context.get_constant(types.intp, context.get_abi_sizeof(context.get_data_type(buffer.dtype)))
        shape = [context.cast(builder, a, t, types.intp) for a, t in zip(args[2:], sig.args[2:])]
        strides = [itemsize]
        for extent in reversed(shape[1:]):
            strides.insert(0, builder.mul(strides[0], extent))
        start = context.cast(builder, args[1], sig.args[1], types.intp)
        context.populate_array(out, data=builder.gep(src.data, [start]), shape=cgutils.pack_array(builder, shape),
                               strides=cgutils.pack_array(builder, strides), itemsize=itemsize, meminfo=src.meminfo,
                               parent=None)
        return impl_ret_borrowed(context, builder, out_type, out._getvalue())

    return out_type(buffer, offset, *dims), codegen


@intrinsic
def view2(typingctx, buffer, offset, rows, cols):
    """``buffer[offset : offset + rows * cols].reshape((rows, cols))``, without numba's reshape.

    Parameters
    ----------
    buffer : ndarray, 1-d, contiguous
        The buffer.
    offset : int
        The view's first item.
    rows, cols : int
        Its shape.

    Returns
    -------
    ndarray, shape (rows, cols)
        The view (C order).
    """
    return _view(typingctx, buffer, offset, (rows, cols))


@intrinsic
def view3(typingctx, buffer, offset, a, b, c):
    """``buffer[offset : offset + a * b * c].reshape((a, b, c))``, without numba's reshape.

    Parameters
    ----------
    buffer : ndarray, 1-d, contiguous
        The buffer.
    offset : int
        The view's first item.
    a, b, c : int
        Its shape.

    Returns
    -------
    ndarray, shape (a, b, c)
        The view (C order).
    """
    return _view(typingctx, buffer, offset, (a, b, c))
