"""Build the compiled physics kernel into the package (``grubler._kernel``).

The kernel (``fmu_src/kernel/*.c``, and the spatial chain in
``fmu_src/kernel/spatial/*.c``), the motor model (``motors/kernel/*.c``), the control laws (``controllers/kernel/*.c``) and the co-simulation master's
stepping loop (``fmu_src/system/c/*.c``) are plain C99 with libm only.  They
are compiled as one shared library that the
Python binding (:mod:`grubler.binding`) loads with ctypes; ``_module.c`` gives it
the module entry point Python's build tools expect.  The native FMUs compile the
same sources again without Python (:mod:`grubler.fmi.build`).
"""

from glob import glob

from setuptools import Extension, setup

SOURCES = sorted(glob("fmu_src/kernel/*.c") + glob("motors/kernel/*.c") + glob("controllers/kernel/*.c"))
SOURCES += sorted(glob("fmu_src/system/c/*.c"))  # the co-simulation master's stepping loop (grubler.system.cosim)
SOURCES += sorted(glob("fmu_src/kernel/spatial/*.c"))  # the spatial chain (grubler.mechanism.spatial)

setup(
    ext_modules=[
        Extension(
            "grubler._kernel",
            sources=SOURCES,
            include_dirs=["fmu_src/kernel", "fmu_src/kernel/spatial", "motors/kernel", "controllers/kernel"],
            define_macros=[("GRB_SHARED", "1")],
            extra_compile_args=["-O2", "-std=c99"] if not __import__("sys").platform.startswith("win") else [],
        )
    ]
)
