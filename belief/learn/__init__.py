"""Mass functions learnt from data: the evidential k-nearest-neighbour classifier, likelihoods and counts.

* :class:`EKNN`: Denœux's evidential k-nearest-neighbour rule (1995).  Each of the k training rows
  nearest to a query is a piece of evidence for its own class, the weaker the farther it lies, and
  the k pieces are fused by Dempster's rule.  Fit it on labelled rows, then ask for a
  :class:`~belief.batch.MassBatch` per query set (:meth:`EKNN.predict_mass`) or for labels
  (:meth:`EKNN.predict`), in the manner of scikit-learn (which is not needed).
* :func:`consonant_from_likelihood`: Shafer's consonant mass function whose plausibility of each
  hypothesis is its normalised likelihood.
* :func:`idm_from_counts`: the imprecise Dirichlet model of observed counts.

The classifier is in :mod:`belief.learn.eknn`, its distances in :mod:`belief.learn.distances`, the two
functions in :mod:`belief.learn.likelihoods` and the errors in :mod:`belief.learn.inputs`; all of them
are imported from here.

Every result lives under Shafer's model of a frame whose hypotheses are the class labels (written
as strings), so it can be fused with any other source on that frame by :func:`~belief.rules.combine`.

References: T. Denœux, *A k-nearest neighbor classification rule based on Dempster–Shafer theory*,
IEEE Trans. SMC 25(5), 1995; L. M. Zouhal and T. Denœux, *An evidence-theoretic k-NN rule with
parameter optimization*, IEEE Trans. SMC C 28(2), 1998; G. Shafer, *A Mathematical Theory of
Evidence*, 1976, ch. 10; P. Walley, *Inferences from multinomial data: learning about a bag of
marbles*, JRSS B 58(1), 1996.
"""

from belief.learn.distances import default_gamma, mean_pairwise_distance
from belief.learn.eknn import EKNN, NEIGHBOUR_SEARCHES
from belief.learn.inputs import LearningDataError, LearningOptionError, NotFittedError
from belief.learn.likelihoods import consonant_from_likelihood, idm_from_counts

__all__ = [
    "EKNN",
    "consonant_from_likelihood",
    "idm_from_counts",
    "LearningDataError",
    "LearningOptionError",
    "NotFittedError",
    "NEIGHBOUR_SEARCHES",
    "default_gamma",
    "mean_pairwise_distance",
]
