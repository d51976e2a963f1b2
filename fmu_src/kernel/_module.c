/* The Python module entry point of grubler._kernel.
 *
 * The kernel is called through ctypes (grubler/binding.py), not through the
 * CPython API; this empty module only lets setuptools build and install the
 * shared library like any extension (and lets `import grubler._kernel` find
 * its file).  The native FMUs do not compile this file. */
#include <Python.h>

static struct PyModuleDef kernel_module = {PyModuleDef_HEAD_INIT, "_kernel",
                                           "The grubler physics kernel (called through ctypes).", -1, NULL};

PyMODINIT_FUNC PyInit__kernel(void) { return PyModule_Create(&kernel_module); }
