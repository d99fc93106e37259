"""Posteriors: emcee samples around a fit, with the linear parameters marginalised.

:mod:`.target` is the log-posterior (its batched designs from :mod:`.design`),
:mod:`.truncnorm` the box-restricted Gaussian of the linear coefficients,
:mod:`.chain` runs and diagnoses emcee, :mod:`.energy` keeps draws that
conserve energy, :mod:`.result` holds the :class:`Posterior`;
:func:`sample_posterior` (:mod:`.sample`, its options checked in
:mod:`.options`) ties them together.
"""

from .result import Posterior
from .sample import sample_posterior

__all__ = ["Posterior", "sample_posterior"]
