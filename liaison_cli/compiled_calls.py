"""Compiled functions handed to compiled functions by address, so a caller's compiled code holds no copy of
theirs.

numba links the machine code of every function a compiled function calls into the caller's own library, and
its cache keeps each library whole: `run_ekf`, LinCov and the batch each carried, and compiled again, the
whole propagator and measurement tree (LinCov's cache entry was 911 KB, 494 KB of it the time update's tree;
`liaison errors` after `liaison run` spent 4.5 of its 8 s of compiling in LinCov's own lowering, mostly LLVM
generating code it already had). A `SharedCall` is an argument instead: numba types it as a first-class
function of one signature (`numba.types.FunctionType`), and the caller calls it through the address of the
function's own cached code, in numba's calling convention, so an exception raised in it still reaches the
caller. The callee is compiled, or loaded from the cache, once, and every estimator shares it.

numba fills in that address (a FunctionType value's `jit_addr`) only for its own dispatchers at the boundary
from Python (numba.experimental.function_type._get_jit_address); `install()` teaches it a SharedCall's. Without
the address numba would call the function's C wrapper, which cannot pass an exception on.

A SharedCall's signature is built from example arguments (`numba.typeof`), so it names exactly the types the
caller passes; a caller that passes others fails to compile or to call (numba: "mismatch of argument types"),
never silently. The estimators' shared calls are typed for C-contiguous writable arrays
(estimation.kernel_args.writable_c at their entry points). Under NUMBA_DISABLE_JIT a dispatcher is the plain
Python function, which is passed as it is.
"""

import numba
import numpy as np
from numba.core.types.function_type import WrapperAddressProtocol
from numba.experimental import function_type

_shared = {}  # (dispatcher, signature) -> SharedCall: one object, one compile result, per signature


class SharedCall(WrapperAddressProtocol):
    """One compiled signature of a numba dispatcher, passed to compiled code as a function argument."""

    def __init__(self, dispatcher, signature):
        self.dispatcher, self._signature = dispatcher, signature
        # By its argument types alone, as a call from compiled code or Python compiles it: numba's cache keys an
        # entry on the signature it was compiled for, and one with the return type named would be another entry.
        dispatcher.compile(signature.args)  # compiles it, or loads it from the cache
        self._result = dispatcher.overloads[signature.args]
        if self._result.signature.return_type != signature.return_type:
            raise TypeError(f"{dispatcher.py_func.__qualname__} returns {self._result.signature.return_type}, "
                            f"not {signature.return_type}")
        library, names = self._result.library, self._result.fndesc
        # Looked up once: numba asks for both at every call from Python that passes this object.
        self._wrapper_address = library.get_pointer_to_function(names.llvm_cfunc_wrapper_name)
        self._jit_address = library.get_pointer_to_function(names.llvm_func_name)

    def signature(self):
        return self._signature

    def __wrapper_address__(self):
        return self._wrapper_address

    def jit_address(self):
        return self._jit_address


def shared_call(dispatcher, return_type, *example_args) -> SharedCall:
    """The SharedCall of `dispatcher` for arguments of example_args' types (numba.typeof) returning
    return_type (a numba type). Found again by _type_key, not numba.typeof: an estimator asks at every call,
    and typing its named groups cost 0.7 ms, 4 % of a 10-day eml2_lunar run."""
    if not hasattr(dispatcher, "overloads"):  # NUMBA_DISABLE_JIT: the plain Python function is its own call
        return dispatcher
    key = (dispatcher, return_type, tuple(_type_key(a) for a in example_args))
    if key not in _shared:
        _shared[key] = SharedCall(dispatcher, return_type(*(numba.typeof(a) for a in example_args)))
    return _shared[key]


def _type_key(value):
    """What numba.typeof reads of a value, as a hashable key: an array's dtype, dimensions, layout, write flag and
    alignment; a named tuple's class and its fields' keys; a scalar's Python type."""
    if isinstance(value, np.ndarray):
        flags = value.flags  # numba's layout: C where C-contiguous (a (1, 6) array is F-contiguous too), else F or A
        layout = "C" if flags.c_contiguous else "F" if flags.f_contiguous else "A"
        return (value.dtype.str, value.ndim, layout, flags.writeable, flags.aligned)
    if isinstance(value, tuple):
        return (type(value), tuple(_type_key(field) for field in value))
    return type(value)


def writable_c(array) -> np.ndarray:
    """array as float64, C-contiguous and writable (a copy only where it is not). numba compiles a function once
    more for a read-only or strided array, and passes none where a shared call is typed for a writable contiguous
    one: every Python caller of a compiled kernel hands its arrays over this way."""
    return np.require(array, np.float64, ("C", "W"))


def _jit_address(func, signature, _numba_own=function_type._get_jit_address):
    if isinstance(func, SharedCall):
        return func.jit_address()
    return _numba_own(func, signature)


def install() -> None:
    """Let numba find a SharedCall's own address when it crosses from Python into compiled code."""
    function_type._get_jit_address = _jit_address


install()
