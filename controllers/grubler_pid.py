"""FMI 2.0 co-simulation slave (pythonfmu): discrete PID controller with setpoint weights, filtered derivative, anti-windup and output limits.

Thin by design: the variables, sample-and-hold and state handling are
:class:`grubler.controllers.fmu.LawSlave`'s, the law is
:class:`grubler.controllers.pid.PID`.  The script's file name is unique among
the project's FMUs, since two pythonfmu slaves whose scripts share a name cannot
be loaded in one process.
"""

import sys
from pathlib import Path

# inside the FMU the package sits beside this script, in resources/
_here = Path(__file__).resolve().parent
if (_here / "grubler" / "__init__.py").is_file() and str(_here) not in sys.path:
    sys.path.insert(0, str(_here))

from grubler.controllers import pid as _law  # noqa: E402
from grubler.controllers.fmu import LawSlave  # noqa: E402
from grubler.fmi_slave import balance_loader_reference  # noqa: E402

balance_loader_reference(globals())  # pythonfmu 0.7's loader, see grubler.fmi_slave


class PID(LawSlave):
    law = _law.PID
