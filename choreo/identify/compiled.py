"""numpy's compiled clip and interp without their Python wrappers, for identify's step loops
(the joint model's, its neighbours'), where a call's overhead is its cost.

``np.clip`` reaches the clip ufunc through three Python calls, ``np.interp`` its compiled
function through one. They live in numpy's private modules (numpy._core from 2.0, numpy.core
before): a numpy that moves them gets the public functions, the same numbers a little slower.
"""

from __future__ import annotations

import numpy as np

_NUMPY_CORE = getattr(np, "_core", None) or getattr(np, "core", None)
clip = getattr(getattr(_NUMPY_CORE, "umath", None), "clip", np.clip)
interp = getattr(getattr(_NUMPY_CORE, "multiarray", None), "interp", np.interp)
