"""Step 3b: the several-contact engine (``method="interior"``): an interior point method on
the cone complementarity problem of the laws ``ccp``, ``dissipative`` and ``coulomb``, finished
by a semismooth Newton method and certified on the original data.

* :mod:`.interior`: the solver path (options, certificates, results);
* :mod:`.interior_point`: the compiled primal-dual interior point (Mehrotra, Nesterov-Todd);
* :mod:`.newton`: the compiled programs and drivers; :mod:`.natural_map`: the semismooth
  Newton finish; :mod:`.certificates`: the certificates that accept an answer on the original
  data;
* :mod:`.lane` and :mod:`.lane_kernel`: the public call's compiled lane for several open-loop
  contacts.

The conic cross-check of every law at several contacts is :mod:`convimpact.impact.conic`.
"""
