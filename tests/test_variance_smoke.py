import numpy as np
import pytest

import allanite
from allanite import reference


@pytest.mark.parametrize("kind", ["overlapping", "standard", "modified", "hadamard", "standard_hadamard", "total"])
@pytest.mark.parametrize("input_kind", ["rate", "angle", "increment"])
def test_kernels_match_reference_multichannel(kind, input_kind):
    rng = np.random.default_rng(7)
    x = rng.standard_normal((500, 3))
    res = allanite.avar(x, 10.0, kind=kind, input=input_kind, taus="all")
    scale = 1.0 if input_kind == "rate" else 100.0
    ref = reference.variance(x, res.m, kind, input=input_kind) * scale
    np.testing.assert_allclose(res.var, ref, rtol=1e-12)
