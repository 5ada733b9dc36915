"""Fixtures shared by the contact engine's tests."""

import numpy as np
import pytest
import scipy.sparse as sp

from convimpact.bench.contact_corpus import corpus
from convimpact.contacts.generalized import GeneralizedFactor


@pytest.fixture(scope="module")
def brick_wall_44():
    """The corpus's 3 x 3 brick wall (44 contacts): W (csr), b (n, d), mu, d and G (W = G G^T)."""
    (case,) = corpus(names=["box-wall-3x3-44"])
    n, d = case.mu.shape[0], case.dim
    G = GeneralizedFactor(case.M, case.J).G
    return (sp.csr_matrix(case.W), np.asarray(case.b, float).reshape(n, d),
            np.asarray(case.mu, float), d, G)
