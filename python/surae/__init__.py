"""surae: triceps-surae Hill-model parameters from an isokinetic dynamometer test with EMG.

The functions run the same code as the ``surae`` command line:

* :func:`envelope` -- normalised EMG envelopes (``surae envelope``);
* :func:`simulate` -- the model's joint torque for an angle and envelopes (``surae simulate``);
* :func:`identify` -- LST, F0 and alpha0 of sol, gm, gl by simulated annealing or MCMC
  (``surae identify``; returns its ``identify.json`` as a dict);
* :func:`diagnose` -- what the model gets wrong (``surae diagnose``; returns
  ``diagnosis.json`` as a dict);
* :func:`design` -- expected posterior sds of candidate protocols (``surae design``;
  returns ``design.json`` as a dict);
* :func:`bundled_trial`, :func:`bundled_unloaded` -- the trial every command uses by default.

Bad input raises :class:`InputError` (a ``ValueError``) with the command line's one-line
message. The guide is ``docs/python.md`` in the repository.
"""

from ._surae import (
    InputError,
    bundled_trial,
    bundled_unloaded,
    design,
    diagnose,
    envelope,
    identify,
    simulate,
)

__version__ = "0.1.0"

__all__ = [
    "InputError",
    "bundled_trial",
    "bundled_unloaded",
    "design",
    "diagnose",
    "envelope",
    "identify",
    "simulate",
]
