"""Grid constants shared by every part of the package (docs/problem.rst)."""

import numpy as np

#: Energy of every trajectory: the particle starts at rest at q = 0, where V(0) = V0.
V0 = 2.0

#: The 100 sensor positions x_j = j / 99 at which a neural operator sees V.
SENSORS = np.linspace(0.0, 1.0, 100)
SENSORS.flags.writeable = False

#: The standard query grid t_i = 2 i / 99 on [0, 2].
TIMES = np.linspace(0.0, 2.0, 100)
TIMES.flags.writeable = False
